//! Subprogram calls as a block writes them: `L123 P3`, `NAME(args)` and `CALL "NAME"`
//! (the runner finds and runs the subprogram).

use super::super::error::GcodeErrorKind;
use super::{Failure, Rewritten, Translator};

/// A subprogram call: `L123 P3`, `POCKET(5, , 2)`, `CALL "NAME"`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Call {
    /// Where the call is written in its line.
    pub offset: usize,
    /// The call as written (for messages).
    pub word: String,
    /// The subprogram's name, upper case (`L123`, `POCKET`).
    pub name: String,
    /// The arguments, by position; `None` where one is left out (`POCKET(, 3)`).
    pub args: Vec<Option<f64>>,
    /// How many times it runs (`P`).
    pub repeat: u32,
}

impl Translator {
    /// `L123` at `name_start` (`i` after the `L`): a call of subprogram `L123`; the offset
    /// after it.
    pub(super) fn numbered_call(
        &mut self,
        upper: &str,
        name_start: usize,
        i: usize,
        out: &mut Rewritten,
    ) -> Result<usize, Failure> {
        let end = upper[i..]
            .find(|c: char| !c.is_ascii_digit())
            .map_or(upper.len(), |e| i + e);
        if end == i {
            return Err((name_start, GcodeErrorKind::MissingValue('L')));
        }
        self.set_call(name_start, &upper[name_start..end], Vec::new(), out)?;
        Ok(end)
    }

    /// `NAME` or `NAME(a, , c)` at `name_start` (`i` after the name): a call of subprogram
    /// `NAME`; the offset after it.
    pub(super) fn named_call(
        &mut self,
        upper: &str,
        name: &str,
        name_start: usize,
        mut i: usize,
        out: &mut Rewritten,
    ) -> Result<usize, Failure> {
        // A name may go on with digits and underscores: `POCKET_2`.
        while upper
            .as_bytes()
            .get(i)
            .is_some_and(|c| c.is_ascii_alphanumeric() || *c == b'_')
        {
            i += 1;
        }
        let name = if i > name_start + name.len() {
            &upper[name_start..i]
        } else {
            name
        };
        let mut args = Vec::new();
        if upper.as_bytes().get(i) == Some(&b'(') {
            i += 1;
            loop {
                while upper.as_bytes().get(i) == Some(&b' ') {
                    i += 1;
                }
                match upper.as_bytes().get(i) {
                    Some(b',') => {
                        args.push(None);
                        i += 1;
                        continue;
                    }
                    Some(b')') => {
                        // `NAME()` has no argument; `NAME(1,)` leaves its last one out.
                        if upper.as_bytes()[i - 1] == b',' {
                            args.push(None);
                        }
                        i += 1;
                        break;
                    }
                    None => {
                        return Err((
                            name_start,
                            GcodeErrorKind::Invalid(format!("{name}( … ) is not closed")),
                        ));
                    }
                    Some(_) => {}
                }
                let (v, n) = self.expression(upper, i, name_start)?;
                args.push(Some(v));
                i += n;
                while upper.as_bytes().get(i) == Some(&b' ') {
                    i += 1;
                }
                match upper.as_bytes().get(i) {
                    Some(b',') => i += 1,
                    Some(b')') => {
                        i += 1;
                        break;
                    }
                    _ => {
                        return Err((
                            i,
                            GcodeErrorKind::Invalid(format!(
                                "{name}( … ): ',' or ')' expected after an argument"
                            )),
                        ));
                    }
                }
            }
        }
        self.set_call(name_start, name, args, out)?;
        Ok(i)
    }

    /// Records the block's subprogram call (one per block).
    fn set_call(
        &mut self,
        offset: usize,
        name: &str,
        args: Vec<Option<f64>>,
        out: &mut Rewritten,
    ) -> Result<(), Failure> {
        out.plain = false;
        if let Some(first) = &self.call {
            return Err((
                offset,
                GcodeErrorKind::Invalid(format!(
                    "{name}: a block calls one subprogram, and this one calls {} already",
                    first.name
                )),
            ));
        }
        self.call = Some(Call {
            offset,
            word: name.to_string(),
            name: name.to_string(),
            args,
            repeat: 1,
        });
        Ok(())
    }

    /// `CALL "NAME"` at `name_start` (`i` after `CALL`): the offset after it.
    pub(super) fn quoted_call(
        &mut self,
        upper: &str,
        name_start: usize,
        i: usize,
        out: &mut Rewritten,
    ) -> Result<usize, Failure> {
        let open = i + upper[i..].len() - upper[i..].trim_start().len();
        let closed = upper[open..]
            .strip_prefix('"')
            .and_then(|rest| rest.find('"'))
            .map(|e| open + 1 + e);
        let Some(close) = closed else {
            return Err((
                name_start,
                GcodeErrorKind::Invalid("CALL needs the subprogram's name in quotes".into()),
            ));
        };
        let path = &upper[open + 1..close];
        // A name with its folder, `"/_N_SPF_DIR/_N_POCK_SPF"`: the subprogram's own name.
        let file = path.rsplit('/').next().unwrap_or(path);
        let name = file
            .strip_prefix("_N_")
            .unwrap_or(file)
            .trim_end_matches("_SPF")
            .trim_end_matches("_MPF");
        self.set_call(name_start, name, Vec::new(), out)?;
        if let Some(call) = &mut self.call {
            call.word = upper[name_start..=close].to_string();
        }
        Ok(close + 1)
    }

    /// The subprogram the last block calls, to be run after its other words.
    pub(crate) fn take_call(&mut self) -> Option<Call> {
        self.call.take()
    }

    /// Whether the last block returned from the subprogram (`M17`, `RET`).
    pub(crate) fn take_returned(&mut self) -> bool {
        std::mem::take(&mut self.returned)
    }
}

//! MATLAB's level-5 MAT-file container (what `save` writes up to `-v7`, compressed or not, and
//! what capture tools such as dSPACE ControlDesk, Simulink and SciPy's `savemat` write),
//! decoded into plain values: numbers, text, structures, cells.
//!
//! The layout follows MathWorks' published "MAT-File Format" (level 5): a 128-byte header
//! whose last two bytes say the byte order, then data elements, each an 8-byte tag (type,
//! size) — or a 4-byte "small" tag with up to 4 bytes of data — followed by its data padded
//! to 8 bytes. A variable is a `miMATRIX` element: array flags (class, complex, logical),
//! dimensions, name, then the class's own parts; `miCOMPRESSED` wraps one element in zlib.
//!
//! Why our own decoder: real writers use freedoms of the format that young readers trip on
//! (ControlDesk stores text as `miUINT16`, empty text as zero-length data, a double scalar as
//! `miUINT8`, integer classes for flags). Every length here is checked against the bytes
//! that are there, so a damaged or hostile file is an error naming its byte offset, never a
//! panic or an allocation the file did not pay for.

use std::io::Read;

/// The text every level-5 file begins with.
pub const SIGNATURE: &[u8] = b"MATLAB 5.0 MAT-file";
const HEADER_BYTES: usize = 128;
/// Structures and cells nest; a capture nests two or three deep. Deeper than this is not a
/// file anyone wrote on purpose, and the limit keeps the recursion bounded.
const DEEPEST: usize = 32;
/// The most a compressed element may expand to (bytes): far beyond any trace, short of
/// exhausting memory on a file built to do so.
const LARGEST_EXPANSION: u64 = 4 << 30;

/// Data element types (the file's `mi…` codes).
mod mi {
    pub const INT8: u32 = 1;
    pub const UINT8: u32 = 2;
    pub const INT16: u32 = 3;
    pub const UINT16: u32 = 4;
    pub const INT32: u32 = 5;
    pub const UINT32: u32 = 6;
    pub const SINGLE: u32 = 7;
    pub const DOUBLE: u32 = 9;
    pub const INT64: u32 = 12;
    pub const UINT64: u32 = 13;
    pub const MATRIX: u32 = 14;
    pub const COMPRESSED: u32 = 15;
    pub const UTF8: u32 = 16;
    pub const UTF16: u32 = 17;
    pub const UTF32: u32 = 18;
}

/// Array classes (the `mx…` codes in an array's flags).
mod mx {
    pub const CELL: u32 = 1;
    pub const STRUCT: u32 = 2;
    pub const OBJECT: u32 = 3;
    pub const CHAR: u32 = 4;
    pub const SPARSE: u32 = 5;
    pub const DOUBLE: u32 = 6;
    pub const UINT64: u32 = 15;
}

const COMPLEX_FLAG: u32 = 0x0800;

/// A decoded MATLAB value.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    /// A numeric or logical array, column-major, as f64; only the real part of a complex one.
    Numeric {
        /// MATLAB's dimensions (at least two).
        dims: Vec<usize>,
        /// The values, column-major.
        real: Vec<f64>,
        /// Whether the array was complex (its imaginary part is dropped).
        complex: bool,
    },
    /// A character array; the rows of a several-row array joined by newlines.
    Text(String),
    /// A structure array: field names, then per element (column-major) one value per field.
    Struct {
        /// MATLAB's dimensions of the array.
        dims: Vec<usize>,
        /// Field names in the file's order.
        fields: Vec<String>,
        /// For each element, its fields' values in the order of `fields`.
        elements: Vec<Vec<Value>>,
    },
    /// A cell array, column-major.
    Cell(Vec<Value>),
    /// An empty value written without parts (a zero-length `miMATRIX`).
    Empty,
    /// A value of a class that holds no signals (sparse, object, function handle, opaque).
    Other(&'static str),
}

impl Value {
    /// The value of field `name` in a structure's first element.
    pub(crate) fn field(&self, name: &str) -> Option<&Value> {
        let Value::Struct {
            fields, elements, ..
        } = self
        else {
            return None;
        };
        let k = fields.iter().position(|f| f == name)?;
        elements.first()?.get(k)
    }

    /// The text of a character array.
    pub(crate) fn text(&self) -> Option<&str> {
        match self {
            Value::Text(s) => Some(s),
            _ => None,
        }
    }
}

/// A top-level variable.
#[derive(Debug, Clone, PartialEq)]
pub struct Variable {
    /// Its name in the workspace.
    pub name: String,
    /// Its value.
    pub value: Value,
}

/// Why a file could not be decoded.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Mat5Error {
    /// The file has no bytes at all.
    #[error("an empty file (0 bytes): no MAT-file header, no variables")]
    Empty,
    /// The header is not a level-5 header.
    #[error("not a MATLAB level-5 MAT-file: {0}")]
    NotLevel5(String),
    /// The contents contradict the format at this byte offset (of the file, or of the
    /// expanded data of a compressed element).
    #[error("damaged at byte {offset}{inside}: {problem}", inside = if *.compressed { " of a compressed variable" } else { "" })]
    Damaged {
        /// Byte offset where the problem was found.
        offset: usize,
        /// Whether the offset counts inside a compressed element's expanded data.
        compressed: bool,
        /// What is wrong.
        problem: String,
    },
}

/// Decodes every variable of a level-5 MAT-file.
pub(crate) fn read(bytes: &[u8]) -> Result<Vec<Variable>, Mat5Error> {
    let order = header_byte_order(bytes)?;
    let mut top = Cursor {
        bytes,
        pos: HEADER_BYTES,
        order,
        compressed: false,
    };
    let mut variables = Vec::new();
    // Fewer than 8 bytes cannot hold an element: they are the last element's padding.
    while top.bytes.len() - top.pos >= 8 {
        let at = top.pos;
        let (kind, data) = top.element()?;
        match kind {
            mi::MATRIX => variables.push(top.sub(data, at + 8).variable(0)?),
            mi::COMPRESSED => {
                let expanded = inflate(data).map_err(|e| top.damaged(at, e))?;
                let mut inner = Cursor {
                    bytes: &expanded,
                    pos: 0,
                    order,
                    compressed: true,
                };
                let (kind, data) = inner.element()?;
                if kind != mi::MATRIX {
                    return Err(inner.damaged(0, format!("a compressed element of type {kind}")));
                }
                variables.push(inner.sub(data, 8).variable(0)?);
            }
            other => {
                return Err(top.damaged(
                    at,
                    format!("a top-level element of type {other}, not a variable"),
                ));
            }
        }
    }
    Ok(variables)
}

/// The byte order the header declares (the text `MI` written as a 16-bit number).
fn header_byte_order(bytes: &[u8]) -> Result<Order, Mat5Error> {
    if bytes.is_empty() {
        return Err(Mat5Error::Empty);
    }
    if bytes.len() < HEADER_BYTES || !bytes.starts_with(SIGNATURE) {
        return Err(Mat5Error::NotLevel5(
            "no 128-byte header starting 'MATLAB 5.0 MAT-file'".into(),
        ));
    }
    match &bytes[126..128] {
        b"IM" => Ok(Order::Little),
        b"MI" => Ok(Order::Big),
        other => Err(Mat5Error::NotLevel5(format!(
            "the byte-order mark is {other:02x?}, neither 'IM' nor 'MI'"
        ))),
    }
}

fn inflate(data: &[u8]) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    flate2::read::ZlibDecoder::new(data)
        .take(LARGEST_EXPANSION)
        .read_to_end(&mut out)
        .map_err(|e| format!("a compressed element does not expand: {e}"))?;
    Ok(out)
}

#[derive(Debug, Clone, Copy)]
enum Order {
    Little,
    Big,
}

/// A position in a run of data elements.
struct Cursor<'a> {
    bytes: &'a [u8],
    pos: usize,
    order: Order,
    compressed: bool,
}

impl<'a> Cursor<'a> {
    /// A cursor over `data`, which starts at `offset` of this cursor's bytes (for messages).
    fn sub(&self, data: &'a [u8], offset: usize) -> SubCursor<'a> {
        SubCursor {
            cursor: Cursor {
                bytes: data,
                pos: 0,
                order: self.order,
                compressed: self.compressed,
            },
            offset,
        }
    }

    fn damaged(&self, offset: usize, problem: impl Into<String>) -> Mat5Error {
        Mat5Error::Damaged {
            offset,
            compressed: self.compressed,
            problem: problem.into(),
        }
    }

    fn u32_at(&self, at: usize) -> u32 {
        let b = [
            self.bytes[at],
            self.bytes[at + 1],
            self.bytes[at + 2],
            self.bytes[at + 3],
        ];
        match self.order {
            Order::Little => u32::from_le_bytes(b),
            Order::Big => u32::from_be_bytes(b),
        }
    }

    /// The next element's type and data; the cursor moves past it and its padding.
    fn element(&mut self) -> Result<(u32, &'a [u8]), Mat5Error> {
        let at = self.pos;
        if self.bytes.len() - at < 8 {
            return Err(self.damaged(at, "the data ends inside an element's tag"));
        }
        let first = self.u32_at(at);
        // A small element packs its size into the upper half of the first word and its data
        // (at most 4 bytes) into the second.
        if first >> 16 != 0 {
            let size = (first >> 16) as usize;
            if size > 4 {
                return Err(self.damaged(at, format!("a small element of {size} bytes")));
            }
            self.pos = at + 8;
            return Ok((first & 0xffff, &self.bytes[at + 4..at + 4 + size]));
        }
        let size = self.u32_at(at + 4) as usize;
        let start = at + 8;
        let Some(end) = start.checked_add(size).filter(|&e| e <= self.bytes.len()) else {
            return Err(self.damaged(
                at,
                format!(
                    "an element of {size} bytes, but only {} follow",
                    self.bytes.len() - start
                ),
            ));
        };
        // Compressed elements are not padded; every other element is, to 8 bytes. A writer
        // that leaves the last element's padding off loses nothing.
        let padded = if first == mi::COMPRESSED {
            end
        } else {
            end.next_multiple_of(8)
        };
        self.pos = padded.min(self.bytes.len());
        Ok((first, &self.bytes[start..end]))
    }
}

/// A cursor inside one `miMATRIX`, with the offset of its data for messages.
struct SubCursor<'a> {
    cursor: Cursor<'a>,
    offset: usize,
}

impl<'a> SubCursor<'a> {
    fn damaged(&self, problem: impl Into<String>) -> Mat5Error {
        self.cursor.damaged(self.offset + self.cursor.pos, problem)
    }

    fn element(&mut self) -> Result<(u32, &'a [u8]), Mat5Error> {
        self.cursor.element().map_err(|e| match e {
            Mat5Error::Damaged {
                offset,
                compressed,
                problem,
            } => Mat5Error::Damaged {
                offset: offset + self.offset,
                compressed,
                problem,
            },
            other => other,
        })
    }

    /// A named variable: the array's name, then its value.
    fn variable(mut self, depth: usize) -> Result<Variable, Mat5Error> {
        let (name, value) = self.array(depth)?;
        Ok(Variable { name, value })
    }

    /// One array (the contents of a `miMATRIX`): its name and value.
    fn array(&mut self, depth: usize) -> Result<(String, Value), Mat5Error> {
        if self.cursor.bytes.is_empty() {
            return Ok((String::new(), Value::Empty));
        }
        if depth > DEEPEST {
            return Err(self.damaged(format!("values nested deeper than {DEEPEST}")));
        }
        let (kind, flags) = self.element()?;
        if kind != mi::UINT32 || flags.len() < 8 {
            return Err(self.damaged("an array without its flags"));
        }
        let word = self.cursor_u32(flags);
        let class = word & 0xff;
        let complex = word & COMPLEX_FLAG != 0;
        let dims = self.dims()?;
        let (_, name) = self.element()?;
        let name = String::from_utf8_lossy(name).into_owned();
        let count = dims
            .iter()
            .try_fold(1usize, |n, &d| n.checked_mul(d))
            .ok_or_else(|| self.damaged(format!("dimensions {dims:?} overflow")))?;
        let value = match class {
            mx::DOUBLE..=mx::UINT64 => self.numeric(dims, count, complex)?,
            mx::CHAR => self.char_array(&dims, count)?,
            mx::STRUCT => self.structure(dims, count, depth)?,
            mx::OBJECT => Value::Other("object"),
            mx::CELL => {
                let mut cells = Vec::new();
                for _ in 0..count {
                    cells.push(self.nested(depth)?.1);
                }
                Value::Cell(cells)
            }
            mx::SPARSE => Value::Other("sparse"),
            _ => Value::Other("opaque"),
        };
        Ok((name, value))
    }

    fn cursor_u32(&self, data: &[u8]) -> u32 {
        let b = [data[0], data[1], data[2], data[3]];
        match self.cursor.order {
            Order::Little => u32::from_le_bytes(b),
            Order::Big => u32::from_be_bytes(b),
        }
    }

    fn dims(&mut self) -> Result<Vec<usize>, Mat5Error> {
        let (kind, data) = self.element()?;
        if kind != mi::INT32 || data.len() < 8 || data.len() % 4 != 0 {
            return Err(self.damaged("an array without its dimensions"));
        }
        let dims: Vec<i64> = numbers(mi::INT32, data, self.cursor.order)
            .unwrap_or_default()
            .into_iter()
            .map(|d| d as i64)
            .collect();
        if dims.iter().any(|&d| d < 0) {
            return Err(self.damaged(format!("negative dimensions {dims:?}")));
        }
        Ok(dims.into_iter().map(|d| d as usize).collect())
    }

    /// A sub-array of a structure or cell: a `miMATRIX` element.
    fn nested(&mut self, depth: usize) -> Result<(String, Value), Mat5Error> {
        let at = self.offset + self.cursor.pos;
        let (kind, data) = self.element()?;
        if kind != mi::MATRIX {
            return Err(self.cursor.damaged(
                at,
                format!("an element of type {kind} where an array belongs"),
            ));
        }
        SubCursor {
            cursor: Cursor {
                bytes: data,
                pos: 0,
                order: self.cursor.order,
                compressed: self.cursor.compressed,
            },
            offset: at + 8,
        }
        .array(depth + 1)
    }

    fn numeric(
        &mut self,
        dims: Vec<usize>,
        count: usize,
        complex: bool,
    ) -> Result<Value, Mat5Error> {
        let (kind, data) = self.element()?;
        let real = numbers(kind, data, self.cursor.order)
            .ok_or_else(|| self.damaged(format!("numbers stored as type {kind}")))?;
        if real.len() != count {
            return Err(self.damaged(format!("{} numbers for dimensions {dims:?}", real.len())));
        }
        Ok(Value::Numeric {
            dims,
            real,
            complex,
        })
    }

    fn char_array(&mut self, dims: &[usize], count: usize) -> Result<Value, Mat5Error> {
        let (kind, data) = self.element()?;
        let chars = characters(kind, data, self.cursor.order)
            .ok_or_else(|| self.damaged(format!("text stored as type {kind}")))?;
        if chars.len() != count {
            // UTF-8 may take several bytes a character; keep what decodes.
            if kind == mi::UTF8 {
                return Ok(Value::Text(chars.into_iter().collect()));
            }
            return Err(self.damaged(format!(
                "{} characters for dimensions {dims:?}",
                chars.len()
            )));
        }
        let rows = dims.first().copied().unwrap_or(1).max(1);
        let columns = count / rows;
        // Stored column-major: row r is every rows-th character from r.
        let lines: Vec<String> = (0..rows)
            .map(|r| (0..columns).map(|c| chars[c * rows + r]).collect())
            .collect();
        Ok(Value::Text(lines.join("\n")))
    }

    fn structure(
        &mut self,
        dims: Vec<usize>,
        count: usize,
        depth: usize,
    ) -> Result<Value, Mat5Error> {
        let (_, length) = self.element()?;
        let name_length = numbers(mi::INT32, length, self.cursor.order)
            .and_then(|v| v.first().copied())
            .filter(|&l| l >= 1.0)
            .ok_or_else(|| self.damaged("a structure without its field-name length"))?
            as usize;
        let (_, names) = self.element()?;
        let fields: Vec<String> = names
            .chunks(name_length)
            .filter(|c| c.len() == name_length)
            .map(|c| {
                let end = c.iter().position(|&b| b == 0).unwrap_or(c.len());
                String::from_utf8_lossy(&c[..end]).into_owned()
            })
            .collect();
        // Elements without fields take no bytes: their number is the dimensions' word alone,
        // and no storage is spent on what a file did not pay for.
        if fields.is_empty() {
            return Ok(Value::Struct {
                dims,
                fields,
                elements: Vec::new(),
            });
        }
        let mut elements = Vec::new();
        for _ in 0..count {
            let mut element = Vec::with_capacity(fields.len());
            for _ in 0..fields.len() {
                element.push(self.nested(depth)?.1);
            }
            elements.push(element);
        }
        Ok(Value::Struct {
            dims,
            fields,
            elements,
        })
    }
}

/// The numbers stored in a data element of type `kind`; `None` for a non-numeric type.
fn numbers(kind: u32, data: &[u8], order: Order) -> Option<Vec<f64>> {
    fn each<const N: usize>(
        data: &[u8],
        order: Order,
        f: impl Fn([u8; N]) -> (f64, f64),
    ) -> Vec<f64> {
        data.chunks_exact(N)
            .map(|c| {
                let mut b = [0u8; N];
                b.copy_from_slice(c);
                let (le, be) = f(b);
                match order {
                    Order::Little => le,
                    Order::Big => be,
                }
            })
            .collect()
    }
    Some(match kind {
        mi::INT8 => data.iter().map(|&b| f64::from(b as i8)).collect(),
        mi::UINT8 => data.iter().map(|&b| f64::from(b)).collect(),
        mi::INT16 => each(data, order, |b| {
            (
                f64::from(i16::from_le_bytes(b)),
                f64::from(i16::from_be_bytes(b)),
            )
        }),
        mi::UINT16 => each(data, order, |b| {
            (
                f64::from(u16::from_le_bytes(b)),
                f64::from(u16::from_be_bytes(b)),
            )
        }),
        mi::INT32 => each(data, order, |b| {
            (
                f64::from(i32::from_le_bytes(b)),
                f64::from(i32::from_be_bytes(b)),
            )
        }),
        mi::UINT32 => each(data, order, |b| {
            (
                f64::from(u32::from_le_bytes(b)),
                f64::from(u32::from_be_bytes(b)),
            )
        }),
        mi::SINGLE => each(data, order, |b| {
            (
                f64::from(f32::from_le_bytes(b)),
                f64::from(f32::from_be_bytes(b)),
            )
        }),
        mi::DOUBLE => each(data, order, |b| {
            (f64::from_le_bytes(b), f64::from_be_bytes(b))
        }),
        mi::INT64 => each(data, order, |b| {
            (i64::from_le_bytes(b) as f64, i64::from_be_bytes(b) as f64)
        }),
        mi::UINT64 => each(data, order, |b| {
            (u64::from_le_bytes(b) as f64, u64::from_be_bytes(b) as f64)
        }),
        _ => return None,
    })
}

/// The characters stored in a data element of type `kind`: UTF-8, UTF-16 (as MATLAB writes
/// `miUINT16`), UTF-32, or one byte a character.
fn characters(kind: u32, data: &[u8], order: Order) -> Option<Vec<char>> {
    Some(match kind {
        mi::UTF8 => String::from_utf8_lossy(data).chars().collect(),
        mi::INT8 | mi::UINT8 => data.iter().map(|&b| char::from(b)).collect(),
        mi::UINT16 | mi::UTF16 => {
            let units = numbers(mi::UINT16, data, order)?
                .into_iter()
                .map(|u| u as u16);
            char::decode_utf16(units)
                .map(|c| c.unwrap_or(char::REPLACEMENT_CHARACTER))
                .collect()
        }
        mi::UINT32 | mi::UTF32 => numbers(mi::UINT32, data, order)?
            .into_iter()
            .map(|u| char::from_u32(u as u32).unwrap_or(char::REPLACEMENT_CHARACTER))
            .collect(),
        _ => return None,
    })
}

#[cfg(test)]
mod tests;

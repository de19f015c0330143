//! Property tests of the G-code front end: no input panics it. (Soups of RS274/NGC tokens,
//! and that every number is read exactly as `str::parse::<f64>` reads the same text, are
//! tested beside the lexer, whose numbers they share.)

use contourcheck::gcode::{InterpretOptions, parse_program};
use proptest::prelude::*;

/// Fragments real and broken SINUMERIK programs are made of.
const SINUMERIK_FRAGMENTS: &[&str] = &[
    "%_N_P_MPF",
    ";c",
    "N10",
    ":20",
    "G710",
    "G700",
    "G641",
    "G642",
    "G9",
    "G60",
    "G64",
    "G4",
    "F",
    "ADIS=",
    "CTOL=",
    "CR=",
    "X=",
    "Y=",
    "I=",
    "AC(",
    "IC(",
    ")",
    "MSG(\"",
    "\"",
    "(",
    "T=\"",
    "R1=",
    "DEF",
    "GOTOF",
    "LBL:",
    "TRANS",
    "CYCLE72",
    "L12",
    "$P_X",
    "=",
    " ",
    "\n",
    "-",
    ".",
    "G2",
    "G3",
    "G1",
    "G0",
    "G90",
    "G91",
    "M30",
    "M17",
    "RET",
    "SOFT",
    "D1",
    // Subprograms, their sections and parameters; opening angles, scaled and
    // mirrored frames, CASE and the high-speed cycle.
    "%_N_SUB_SPF",
    "PROC SUB(",
    "REAL A",
    ",",
    "SUB(",
    "SUB",
    "CALL \"SUB\"",
    "P2",
    "AR=",
    "SCALE",
    "MIRROR",
    "AMIRROR",
    "ASCALE",
    "CASE(",
    " OF ",
    "DEFAULT",
    "CYCLE832(",
    "BRISK",
    // What CAM posts and other interpreters write around the path.
    " = ",
    " + ",
    " DIV ",
    " MOD ",
    " B_AND ",
    " >= ",
    " XOR ",
    "TRUE",
    "CYCLE800()",
    "CYCLE800(1,",
    "A=",
    "C90",
    "FNORM",
    "SETMS(1)",
    "LABEL_1:",
    "GOTOF 90",
    "N90",
    "FELD[",
    "ACC[X]=",
    "ADISPOS=",
    "CTOLG0=",
    "OTOL=",
];

/// A fragment of a SINUMERIK program, or a number.
fn sinumerik_token() -> impl Strategy<Value = String> {
    prop_oneof![
        prop::sample::select(SINUMERIK_FRAGMENTS).prop_map(str::to_string),
        (-1e4f64..1e4).prop_map(|v| format!("{v}")),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    #[test]
    fn random_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
        let text = String::from_utf8_lossy(&bytes);
        let _ = parse_program(&text, "fuzz.nc", &InterpretOptions::default());
    }

    #[test]
    fn sinumerik_soups_never_panic(tokens in prop::collection::vec(sinumerik_token(), 0..60), bytes in prop::collection::vec(any::<u8>(), 0..40)) {
        let text = format!("{}{}", tokens.concat(), String::from_utf8_lossy(&bytes));
        let _ = parse_program(&text, "soup.mpf", &InterpretOptions::default());
    }
}

/// Deep nesting and long runs must be refused or read, never overflow the stack.
#[test]
fn pathological_lines_are_handled() {
    for text in [
        format!("X{}1{}", "[".repeat(100_000), "]".repeat(100_000)),
        format!("X[{}1]", "-".repeat(100_000)),
        "(".repeat(100_000),
        "G1 ".repeat(50_000),
        format!("X{}", "9".repeat(400)),
    ] {
        let _ = parse_program(&text, "deep.nc", &InterpretOptions::default());
    }
}

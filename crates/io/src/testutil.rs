//! Test helpers shared by the reader tests.

use crate::error::ReadError;
use proptest::prelude::*;

/// Drain a reader; the first error ends it.
pub fn collect<T, I: Iterator<Item = Result<T, ReadError>>>(it: I) -> Result<Vec<T>, ReadError> {
    it.collect()
}

/// Assert an error names `file`, `line` and `field` (in the struct and the message).
#[track_caller]
pub fn assert_err<T: std::fmt::Debug>(
    r: Result<Vec<T>, ReadError>,
    file: &str,
    line: u64,
    field: &str,
) -> ReadError {
    let e = r.expect_err("expected an error");
    let msg = e.to_string();
    assert_eq!((&*e.file, e.line, &*e.field), (file, line, field), "{msg}");
    assert!(
        msg.starts_with(&format!("{file}:{line}: field `{field}`: ")),
        "{msg}"
    );
    e
}

/// Lines made of plausible and implausible tokens, to shake the parsers.
pub fn token_lines() -> impl Strategy<Value = Vec<u8>> {
    let tok = prop_oneof![
        Just("nan".to_string()),
        Just("%".to_string()),
        Just("#".to_string()),
        Just("2025/07/08".to_string()),
        Just("19:34:18.5".to_string()),
        Just("-1e400".to_string()),
        Just("1.0.0".to_string()),
        Just(",".to_string()),
        Just("latitude(deg)".to_string()),
        Just("GPST".to_string()),
        (-1.0e6f64..1.0e6).prop_map(|x| x.to_string()),
        (0u32..3000).prop_map(|x| x.to_string()),
        "[ -~]{0,6}",
    ];
    let line = proptest::collection::vec(tok, 0..26).prop_map(|v| v.join(" "));
    (
        proptest::collection::vec(line, 0..12),
        any::<bool>(),
        proptest::collection::vec(any::<u8>(), 0..4),
    )
        .prop_map(|(lines, nl, junk)| {
            let mut b = lines.join("\n").into_bytes();
            b.extend(junk);
            if nl {
                b.push(b'\n');
            }
            b
        })
}

/// `text` with field `k` of line `l` (0-based) replaced by the bytes `v`.
/// Fields are split at `sep`, or at runs of white space when `sep` is `None`
/// (then rejoined with one space).
pub fn with_field(text: &str, sep: Option<char>, l: usize, k: usize, v: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if i == l {
            let fields: Vec<&str> = match sep {
                Some(c) => line.split(c).collect(),
                None => line.split_whitespace().collect(),
            };
            for (j, x) in fields.iter().enumerate() {
                if j > 0 {
                    out.push(sep.unwrap_or(' ') as u8);
                }
                out.extend_from_slice(if j == k { v } else { x.as_bytes() });
            }
        } else {
            out.extend_from_slice(line.as_bytes());
        }
        out.push(b'\n');
    }
    out
}

//! The one error type of every reader, and the record accounting every
//! reader keeps.
//!
//! An error names the file, the 1-based line and the field:
//! `imu.txt:1234: field `gyro_x`: not a number: "1.2.3"`. Problems that
//! concern a whole line (I/O, a malformed header) use a field name in angle
//! brackets, e.g. `<line>`.

use std::borrow::Cow;
use std::fmt;
use std::sync::Arc;

/// A reader error: `FILE:LINE: field `NAME`: what is wrong`.
#[derive(Clone, Debug, PartialEq)]
pub struct ReadError {
    /// File name as given by the caller (a path, or a label such as `<stdin>`).
    pub file: Arc<str>,
    /// 1-based line number (0 when the file could not be opened at all).
    pub line: u64,
    /// Field name (`gyro_x`, `latitude(deg)`, …) or `<line>`/`<header>`.
    pub field: Cow<'static, str>,
    /// What is wrong, with the offending text quoted where useful.
    pub msg: String,
}

impl fmt::Display for ReadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}:{}: field `{}`: {}",
            self.file, self.line, self.field, self.msg
        )
    }
}

impl std::error::Error for ReadError {}

/// The class of a failure, shared by every navfuse library error so that the
/// `navfuse` CLI maps errors to its documented exit codes (docs/exit-codes.md)
/// without knowing their details.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FailureKind {
    /// Bad command line or configuration (unknown key, wrong type, bad option).
    Usage,
    /// An input data file is missing, malformed, empty or unusable (every
    /// record rejected, no alignment possible).
    Input,
    /// The file system refused: an output cannot be written, the
    /// configuration file cannot be read, a read fails mid-file.
    Io,
    /// A bug: an invariant broke (a panic, a writer thread lost).
    Internal,
}

impl FailureKind {
    /// The process exit code: 2 usage/config, 3 input data, 4 I/O, 70
    /// internal (`EX_SOFTWARE` of BSD sysexits).
    pub fn exit_code(self) -> u8 {
        match self {
            FailureKind::Usage => 2,
            FailureKind::Input => 3,
            FailureKind::Io => 4,
            FailureKind::Internal => 70,
        }
    }
}

impl ReadError {
    /// [`FailureKind::Io`] for a read error of the file system in the middle
    /// of a file (`I/O error`), else [`FailureKind::Input`]: the content is
    /// wrong, or the input file is missing or unreadable (an input that is
    /// not there is the input's problem, like one that is malformed).
    pub fn kind(&self) -> FailureKind {
        if self.msg.starts_with("I/O error") {
            FailureKind::Io
        } else {
            FailureKind::Input
        }
    }

    /// New error; `field` may be a `&'static str` or an owned `String`.
    pub fn new(
        file: &Arc<str>,
        line: u64,
        field: impl Into<Cow<'static, str>>,
        msg: impl Into<String>,
    ) -> Self {
        ReadError {
            file: file.clone(),
            line,
            field: field.into(),
            msg: msg.into(),
        }
    }
}

/// Accounting of the lines of one input: every line is exactly one of
/// used (became a record), skipped (header, comment, blank) or rejected
/// (with a counted reason). After a complete read without error,
/// `lines == used + skipped + rejected_total()`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RecordStats {
    /// Lines read (including header/comment/blank lines).
    pub lines: u64,
    /// Lines that produced a record.
    pub used: u64,
    /// Header, comment and blank lines.
    pub skipped: u64,
    /// Rejected lines by reason (reason, count), in order of first occurrence.
    pub rejected: Vec<(&'static str, u64)>,
}

impl RecordStats {
    /// Count one rejected line under `reason`.
    pub fn reject(&mut self, reason: &'static str) {
        if let Some(e) = self.rejected.iter_mut().find(|e| e.0 == reason) {
            e.1 += 1;
        } else {
            self.rejected.push((reason, 1));
        }
    }

    /// All rejected lines.
    pub fn rejected_total(&self) -> u64 {
        self.rejected.iter().map(|e| e.1).sum()
    }

    /// Rejections counted under `reason` (0 if none).
    pub fn rejected_for(&self, reason: &str) -> u64 {
        self.rejected
            .iter()
            .find(|e| e.0 == reason)
            .map_or(0, |e| e.1)
    }

    /// Whether every line is accounted for.
    pub fn is_balanced(&self) -> bool {
        self.lines == self.used + self.skipped + self.rejected_total()
    }
}

impl fmt::Display for RecordStats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} lines: {} used, {} skipped (header/comment/blank), {} rejected",
            self.lines,
            self.used,
            self.skipped,
            self.rejected_total()
        )?;
        if !self.rejected.is_empty() {
            f.write_str(" (")?;
            for (i, (r, n)) in self.rejected.iter().enumerate() {
                if i > 0 {
                    f.write_str(", ")?;
                }
                write!(f, "{n} {r}")?;
            }
            f.write_str(")")?;
        }
        Ok(())
    }
}

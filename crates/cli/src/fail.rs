//! A command's failure: the message printed after `navfuse: ` and the
//! [`FailureKind`] that picks the exit code (docs/exit-codes.md). The kinds
//! come from the libraries' errors (`ReadError::kind`, `PipelineError::kind`);
//! the CLI only adds them for its own argument checks.

pub use navfuse_pipeline::error::FailureKind;
use std::fmt;

/// A failure with its class.
#[derive(Debug)]
pub struct Fail {
    /// `None`: a command whose errors are not classified yet (exit 1).
    pub kind: Option<FailureKind>,
    pub msg: String,
}

impl Fail {
    pub fn new(kind: FailureKind, msg: impl Into<String>) -> Self {
        Fail {
            kind: Some(kind),
            msg: msg.into(),
        }
    }
    /// A bad option or configuration (exit 2).
    pub fn usage(msg: impl Into<String>) -> Self {
        Fail::new(FailureKind::Usage, msg)
    }
    /// Unusable input data (exit 3).
    pub fn input(msg: impl Into<String>) -> Self {
        Fail::new(FailureKind::Input, msg)
    }
    /// A file-system failure on `path` (exit 4).
    pub fn io(path: &std::path::Path) -> impl FnOnce(std::io::Error) -> Fail + '_ {
        move |e| Fail::new(FailureKind::Io, format!("{}: {e}", path.display()))
    }
    /// The process exit code.
    pub fn exit_code(&self) -> u8 {
        self.kind.map_or(1, FailureKind::exit_code)
    }
}

impl fmt::Display for Fail {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.msg)
    }
}

/// Commands whose errors are not classified yet fail with exit code 1.
impl From<String> for Fail {
    fn from(msg: String) -> Self {
        Fail { kind: None, msg }
    }
}

impl From<navfuse_io::ReadError> for Fail {
    fn from(e: navfuse_io::ReadError) -> Self {
        Fail::new(e.kind(), e.to_string())
    }
}

impl From<navfuse_pipeline::PipelineError> for Fail {
    fn from(e: navfuse_pipeline::PipelineError) -> Self {
        Fail::new(e.kind(), e.to_string())
    }
}

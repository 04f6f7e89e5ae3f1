//! The pipeline's error type. Every variant's `Display` is the message the
//! `navfuse` CLI printed before the pipeline became a library (it prints
//! `e.to_string()`), so messages name the file, line and field as before.

pub use navfuse_io::FailureKind;
use std::path::PathBuf;

/// Errors of the run pipeline.
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    /// A configuration problem, prefixed by the configuration file
    /// (`FILE: MSG`, e.g. a TOML syntax error or an invalid `[outage]`).
    #[error("{file}: {msg}")]
    Config { file: String, msg: String },
    /// An option given by the caller (e.g. `--gate`, `--time-offset`) is invalid.
    #[error("{0}")]
    Options(String),
    /// Reading or joining an input failed; the readers' text
    /// (`file:line: field ...`) is kept verbatim.
    #[error("{0}")]
    Input(String),
    /// The initial attitude/heading cannot be found from the data.
    #[error("{0}")]
    Alignment(String),
    /// Unknown estimator, or the estimator diverged.
    #[error("{0}")]
    Estimator(String),
    /// A file-system error on `path` (`PATH: WHAT SOURCE`, `what` being e.g.
    /// `"cannot read: "` or empty).
    #[error("{}: {what}{source}", path.display())]
    Io {
        path: PathBuf,
        what: &'static str,
        source: std::io::Error,
    },
    /// Writing an output failed other than on the file system (a writer
    /// thread, JSON serialisation).
    #[error("{0}")]
    Output(String),
}

impl PipelineError {
    /// The class of the failure, for the CLI's exit code: configuration and
    /// options → usage; input, alignment and estimator failures → input data
    /// (the data did not allow a solution); file system → I/O; output
    /// serialisation or a lost writer thread → internal.
    pub fn kind(&self) -> FailureKind {
        match self {
            PipelineError::Config { .. } | PipelineError::Options(_) => FailureKind::Usage,
            PipelineError::Input(_) | PipelineError::Alignment(_) | PipelineError::Estimator(_) => {
                FailureKind::Input
            }
            PipelineError::Io { .. } => FailureKind::Io,
            PipelineError::Output(_) => FailureKind::Internal,
        }
    }

    /// An [`PipelineError::Io`] on `path` with the message prefix `what`.
    pub fn io(path: impl Into<PathBuf>, what: &'static str) -> impl FnOnce(std::io::Error) -> Self {
        let path = path.into();
        move |source| PipelineError::Io { path, what, source }
    }
}

/// Shorthand for the pipeline's results.
pub type Result<T, E = PipelineError> = std::result::Result<T, E>;

//! The error of the tools built on the pipeline (experiments, the carrier-phase
//! baseline, Allan analysis, the demo, GNSS smoothing, the live session).

/// A tool's failure. Its text names the file, line and field where known and
/// is exactly what `navfuse` prints after `navfuse: `; these tools fail for
/// one reason each (bad option, unreadable or malformed input), so a message
/// is the whole of the error.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct ToolError(pub String);

impl From<String> for ToolError {
    fn from(s: String) -> Self {
        ToolError(s)
    }
}

impl From<&str> for ToolError {
    fn from(s: &str) -> Self {
        ToolError(s.to_string())
    }
}

impl From<ToolError> for String {
    fn from(e: ToolError) -> Self {
        e.0
    }
}

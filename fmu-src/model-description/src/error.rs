use std::fmt;

/// Why a modelDescription.xml was rejected: the file, the line where known, what was being read
/// (an element or a variable) and what was expected instead.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Error {
    /// The file (or the label given to [`crate::parse_str`]).
    pub file: String,
    /// 1-based line of the offending element, where known.
    pub line: Option<usize>,
    /// What was being read, e.g. `variable 'vx' (valueReference 10)` or `<CoSimulation>`.
    pub context: String,
    /// What is wrong and what was expected.
    pub message: String,
}

impl Error {
    pub(crate) fn new(
        file: &str,
        line: Option<usize>,
        context: impl Into<String>,
        message: impl Into<String>,
    ) -> Self {
        Self {
            file: file.to_owned(),
            line,
            context: context.into(),
            message: message.into(),
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(line) => write!(
                f,
                "{}:{}: {}: {}",
                self.file, line, self.context, self.message
            ),
            None => write!(f, "{}: {}: {}", self.file, self.context, self.message),
        }
    }
}

impl std::error::Error for Error {}

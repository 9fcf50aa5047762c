//! The library's error type: every failure says whose fault it is.
//!
//! - [`Error::Invalid`]: the input is malformed (which element, row or line).
//! - [`Error::Truncated`]: the input ended before what its header promised.
//! - [`Error::Unsupported`]: a valid input uses a feature we do not handle.
//! - [`Error::Missing`]: a stage needs an attribute the input does not have;
//!   the message names the stage that makes it.
//! - [`Error::Param`]: a parameter value is out of range; it names the
//!   parameter as the library does (`sd`, a field of a stage's `Params`),
//!   and a binary names the option that sets it (`--sd`).
//! - [`Error::Io`]: the operating system failed us.
//!
//! Messages are one line, without the file name: the binaries add it.

use std::fmt;

/// Result alias used throughout the library.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// A library error. `Display` gives one line without the file name.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Malformed input: the message says where.
    #[error("invalid: {0}")]
    Invalid(String),
    /// The input ended early.
    #[error("truncated: {0}")]
    Truncated(String),
    /// Valid input using something this toolkit does not handle.
    #[error("unsupported: {0}")]
    Unsupported(String),
    /// A required attribute is absent.
    #[error("{0}")]
    Missing(MissingAttr),
    /// A parameter is out of range or not finite.
    #[error("parameter {name}: {what}")]
    Param { name: String, what: String },
    /// An operating-system I/O error. (Transparent: its message is printed
    /// once, not again as its own cause.)
    #[error(transparent)]
    Io(#[from] std::io::Error),
    /// An error about a named input (a file, `<stdin>`): for library
    /// functions that read several inputs, so the message names the one
    /// at fault.
    #[error("{name}: {inner}")]
    In { name: String, inner: Box<Error> },
}

/// A missing attribute, with the stage that makes it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MissingAttr {
    /// Element class: "point", "face", "detail".
    pub class: &'static str,
    /// Attribute name, e.g. `N`.
    pub name: String,
    /// Stage that produces it, e.g. `facet`.
    pub made_by: Option<&'static str>,
}

impl fmt::Display for MissingAttr {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "missing {} attribute '{}'", self.class, self.name)?;
        if let Some(stage) = self.made_by {
            write!(f, " (run '{stage}' first to make it)")?;
        }
        Ok(())
    }
}

impl Error {
    /// Shorthand for [`Error::Invalid`].
    pub fn invalid(msg: impl Into<String>) -> Self {
        Error::Invalid(msg.into())
    }

    /// Shorthand for [`Error::Truncated`].
    pub fn truncated(msg: impl Into<String>) -> Self {
        Error::Truncated(msg.into())
    }

    /// Shorthand for [`Error::Unsupported`].
    pub fn unsupported(msg: impl Into<String>) -> Self {
        Error::Unsupported(msg.into())
    }

    /// Shorthand for [`Error::Param`].
    pub fn param(name: impl Into<String>, what: impl Into<String>) -> Self {
        Error::Param {
            name: name.into(),
            what: what.into(),
        }
    }

    /// A missing attribute of class `class`; the message names the stage
    /// that makes it (the table [`crate::names::MAKERS`]).
    pub fn missing(class: &'static str, name: &str) -> Self {
        Error::Missing(MissingAttr {
            class,
            name: name.to_string(),
            made_by: crate::names::made_by(name),
        })
    }

    /// This error, about the input called `name` (a bad parameter stays
    /// as it is: it is not about a file).
    pub fn about(self, name: &str) -> Self {
        match self {
            Error::Param { .. } => self,
            Error::In { name: ref n, .. } if n == name => self,
            _ => Error::In {
                name: name.to_string(),
                inner: Box::new(self),
            },
        }
    }

    /// Renames the parameters this error is about by `flag`, where it
    /// gives a name: the command line names a library parameter (`sd`) by
    /// the option that sets it (`--sd`).
    pub fn rename_params(&mut self, flag: &dyn Fn(&str) -> Option<String>) {
        match self {
            Error::Param { name, .. } => {
                if let Some(f) = flag(name) {
                    *name = f;
                }
            }
            Error::In { inner, .. } => inner.rename_params(flag),
            _ => {}
        }
    }

    /// True when the error is a bad parameter (also about an input).
    pub fn is_param(&self) -> bool {
        match self {
            Error::Param { .. } => true,
            Error::In { inner, .. } => inner.is_param(),
            _ => false,
        }
    }

    /// True when the error is a broken pipe (the reader went away: `| head`).
    pub fn is_broken_pipe(&self) -> bool {
        match self {
            Error::Io(e) => e.kind() == std::io::ErrorKind::BrokenPipe,
            Error::In { inner, .. } => inner.is_broken_pipe(),
            _ => false,
        }
    }
}

/// Deserialises a JSON file's `text`; an error names `file` and the path
/// of the key at fault (`lights[2].cone_angle: invalid type ...`).
pub fn from_json<T: serde::de::DeserializeOwned>(text: &str, file: &str) -> Result<T> {
    let de = &mut serde_json::Deserializer::from_str(text);
    serde_path_to_error::deserialize(de).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.into_inner();
        let at = if path == "." || path.is_empty() {
            String::new()
        } else {
            format!(" at {path}")
        };
        Error::invalid(format!("{file}{at}: {inner}"))
    })
}

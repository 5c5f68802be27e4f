//! The one error type of `vp-scene`.
//!
//! Every error that comes from a file names the file and the place in it
//! (line, element or byte offset), so that a user can open the file and look.

use std::fmt;
use std::path::PathBuf;

/// Where in a file a problem was found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Location {
    /// 1-based line number of a text file.
    Line(usize),
    /// Byte offset from the start of a binary file.
    Byte(u64),
    /// The `index`-th (0-based) element of a kind ("vertex", "face", "image", ...),
    /// with its byte offset when the file is binary.
    Element {
        /// Kind of element, as the file format names it.
        kind: String,
        /// 0-based index among the elements of that kind.
        index: usize,
        /// Byte offset of the element in a binary file, if known.
        byte: Option<u64>,
    },
    /// The header of the file.
    Header,
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::Line(n) => write!(f, "line {n}"),
            Location::Byte(b) => write!(f, "byte {b}"),
            Location::Element {
                kind,
                index,
                byte: Some(b),
            } => write!(f, "{kind} {index} (byte {b})"),
            Location::Element {
                kind,
                index,
                byte: None,
            } => write!(f, "{kind} {index}"),
            Location::Header => write!(f, "header"),
        }
    }
}

/// Errors of `vp-scene`.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// Opening, reading or writing a file failed at the operating-system level.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file concerned.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// A file's content is malformed at a known place.
    #[error("{}: {location}: {message}", path.display())]
    Parse {
        /// The file concerned.
        path: PathBuf,
        /// Where in the file.
        location: Location,
        /// What is wrong, in words a user understands.
        message: String,
    },
    /// An image file could not be decoded or encoded.
    #[error("{}: {source}", path.display())]
    Image {
        /// The file concerned.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: image::ImageError,
    },
    /// A mesh breaks an invariant (non-finite coordinate, index out of range,
    /// degenerate face, material list of the wrong length).
    #[error("invalid mesh: {0}")]
    InvalidMesh(String),
    /// A value given by the caller is outside its valid range.
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
    /// Surface reconstruction cannot work on the given samples (too few,
    /// non-finite, no normal and no viewpoint, degenerate) or produced nothing.
    #[error("surface reconstruction: {0}")]
    Surface(String),
    /// The output file exists and overwriting was not allowed.
    #[error("{}: already exists (pass --force to overwrite)", path.display())]
    AlreadyExists {
        /// The file that would have been overwritten.
        path: PathBuf,
    },
    /// An output folder was refused before anything was written
    /// ([`crate::outdir`]): it is the current folder, holds an input, or
    /// holds files vpctl did not write.
    #[error("{}: {why}; {fix}", path.display())]
    OutputRefused {
        /// The output folder (or the file in it) at fault.
        path: PathBuf,
        /// Why it is refused.
        why: String,
        /// What to do instead, with the command.
        fix: String,
    },
}

impl SceneError {
    /// Whether the user's input is at fault (exit code 2 in `vpctl`): a
    /// missing or malformed file, a bad argument, refusing to overwrite. An
    /// I/O failure on a file that exists (permissions, a full disk) is not.
    pub fn is_input_error(&self) -> bool {
        let not_found = |e: &std::io::Error| e.kind() == std::io::ErrorKind::NotFound;
        match self {
            SceneError::Io { source, .. } => not_found(source),
            SceneError::Image {
                source: image::ImageError::IoError(e),
                ..
            } => not_found(e),
            _ => true,
        }
    }

    /// Shorthand for [`SceneError::Io`].
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        SceneError::Io {
            path: path.into(),
            source,
        }
    }

    /// Shorthand for [`SceneError::Parse`].
    pub fn parse(path: impl Into<PathBuf>, location: Location, message: impl Into<String>) -> Self {
        SceneError::Parse {
            path: path.into(),
            location,
            message: message.into(),
        }
    }
}

/// Result alias of `vp-scene`.
pub type Result<T, E = SceneError> = std::result::Result<T, E>;

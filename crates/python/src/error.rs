//! Errors of the Python door: a one-line message, as `haptic6d` prints it after `error: `,
//! and which Python exception it becomes.

use std::fmt;

/// Which Python exception a [`Failure`] becomes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FailureKind {
    /// Bad input: a malformed scene or tree file, a setting out of range, an unknown name, an
    /// array of the wrong shape, a non-finite pose (`haptic6d.InputError`, a `ValueError`).
    Value,
    /// A file that cannot be found, read or written (`haptic6d.FileError`, an `OSError`).
    File,
}

/// A refused call: what went wrong, in one line that names the file or argument.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Failure {
    /// Which exception.
    pub kind: FailureKind,
    /// The message (one line).
    pub message: String,
}

impl Failure {
    /// A value error with `message`.
    pub fn value(message: impl Into<String>) -> Self {
        Self {
            kind: FailureKind::Value,
            message: one_line(&message.into()),
        }
    }

    /// A file error with `message`.
    pub fn file(message: impl Into<String>) -> Self {
        Self {
            kind: FailureKind::File,
            message: one_line(&message.into()),
        }
    }

    /// `error` and its chain of sources as the command line prints them
    /// (`outer: inner: innermost`, on one line), of `kind`.
    pub fn chain(kind: FailureKind, error: &dyn std::error::Error) -> Self {
        Self {
            kind,
            message: one_line(&scene::error_chain(error)),
        }
    }
}

impl fmt::Display for Failure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for Failure {}

impl From<scene::SceneError> for Failure {
    fn from(e: scene::SceneError) -> Self {
        let kind = match e {
            scene::SceneError::Io { .. } => FailureKind::File,
            _ => FailureKind::Value,
        };
        Self::chain(kind, &e)
    }
}

impl From<mesh::MeshError> for Failure {
    fn from(e: mesh::MeshError) -> Self {
        let kind = match e {
            mesh::MeshError::Read { .. } => FailureKind::File,
            _ => FailureKind::Value,
        };
        Self::chain(kind, &e)
    }
}

impl From<spheretree::sph::SphError> for Failure {
    fn from(e: spheretree::sph::SphError) -> Self {
        use spheretree::sph::SphError;
        let kind = match e {
            SphError::Read { .. } | SphError::Write { .. } => FailureKind::File,
            _ => FailureKind::Value,
        };
        Self::chain(kind, &e)
    }
}

/// Collapses whitespace runs (newlines included) to single spaces, as the command line does.
fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_chain_is_one_line_outer_first() {
        let inner = std::io::Error::new(std::io::ErrorKind::NotFound, "no such\nfile");
        #[derive(Debug)]
        struct Outer(std::io::Error);
        impl fmt::Display for Outer {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("reading x.toml")
            }
        }
        impl std::error::Error for Outer {
            fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
                Some(&self.0)
            }
        }
        let f = Failure::chain(FailureKind::File, &Outer(inner));
        assert_eq!(f.message, "reading x.toml: no such file");
        assert_eq!(f.kind, FailureKind::File);
    }
}

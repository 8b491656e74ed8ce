//! The library's error type: every variant names the problem and, where there is one, the fix.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("unknown model '{name}'; known models: {known}")]
    UnknownModel { name: String, known: String },
    #[error("{0}")]
    InvalidInput(String),
    #[error("table of {cells} cells × {channels} channels would need {bytes} bytes ({human}), over the limit of {limit_human}; choose a smaller {option}")]
    TooLarge {
        cells: u128,
        channels: usize,
        bytes: u128,
        human: String,
        limit_human: String,
        /// The option that sets the table's size (`--resolution`, `--lut-resolution`, …).
        option: String,
    },
    #[error("{path}: {message}")]
    File { path: PathBuf, message: String },
    #[error("I/O error on {path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error(transparent)]
    Fit(#[from] crate::fit::FitError),
}

pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Error {
        Error::Io {
            path: path.into(),
            source,
        }
    }
    pub fn file(path: impl Into<PathBuf>, message: impl Into<String>) -> Error {
        Error::File {
            path: path.into(),
            message: message.into(),
        }
    }

    /// A table too large for memory ([`Error::TooLarge`]) names `option` as the one to lower,
    /// where the caller knows which option set the table's size; other errors are unchanged.
    pub fn for_option(self, option: &str) -> Error {
        match self {
            Error::TooLarge {
                cells,
                channels,
                bytes,
                human,
                limit_human,
                ..
            } => Error::TooLarge {
                cells,
                channels,
                bytes,
                human,
                limit_human,
                option: option.to_string(),
            },
            e => e,
        }
    }
}

/// Human-readable byte count (binary units).
pub fn human_bytes(bytes: u128) -> String {
    const UNITS: [&str; 6] = ["B", "KiB", "MiB", "GiB", "TiB", "PiB"];
    let mut v = bytes as f64;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < UNITS.len() {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 {
        format!("{bytes} B")
    } else {
        format!("{v:.1} {}", UNITS[u])
    }
}

//! How long computations report what they do to whoever runs them: the CLI draws progress bars
//! on the terminal and prints the lines; a library user may show them or ignore them ([`Quiet`]).
//! Nothing reported here reaches an output file.

/// Receives the progress and the log lines of a long computation. Every method has a default
/// that ignores it. Steps may be reported from several threads at once.
pub trait Observer: Sync {
    /// A line of the run's log (stage headers, what became of each table, fit and file).
    fn line(&self, _text: &str) {}
    /// A task of `total` steps begins; `what` names it.
    fn begin(&self, _what: &str, _total: u64) {}
    /// The current task turned out to have `n` more steps.
    fn extend(&self, _n: u64) {}
    /// The current task's step in progress is now `what`.
    fn message(&self, _what: &str) {}
    /// `n` more steps of the current task are done.
    fn advance(&self, _n: u64) {}
    /// The current task ended.
    fn end(&self) {}
}

/// Reports nothing.
#[derive(Clone, Copy, Debug, Default)]
pub struct Quiet;

impl Observer for Quiet {}

//! A hint for the code generator: which paths are rare.

/// Marks the path that calls it as rarely taken: the compiler lays the other path out as the
/// straight line (no taken branch on it) and keeps the rare path's work out of its way. For
/// the hot paths' fault and fold branches, which a running controller never takes.
#[cold]
pub(crate) fn cold() {}

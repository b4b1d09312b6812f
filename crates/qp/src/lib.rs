//! qp (in progress).

//! mesh (in progress).

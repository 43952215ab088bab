//! Allan-variance tests (being written).

//! Allan-family variances (placeholder, being written).

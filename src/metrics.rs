//! Image comparison (placeholder until the next commit).

//! End-to-end tests of the `lucid` binary live in `tests/`.

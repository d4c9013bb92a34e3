//! Shared helpers of the cross-crate integration tests (the tests are the `[[test]]` targets).

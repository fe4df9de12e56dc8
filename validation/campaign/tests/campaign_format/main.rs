//! The `zmp-campaign/1` reader and writer: round trip, malformed inputs, atomic writing.
//!
//! One test binary; the tests are split by topic into the modules below.

mod csv_errors;
mod fixtures;
mod manifest_errors;
mod reading;
mod writing;

//! Build script: the same run-path handling as the CLI's (`cli/build.rs`), for the
//! `raysplat-bench` binary and this package's tests.

include!("../cli/build.rs");

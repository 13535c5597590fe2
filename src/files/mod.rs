//! The files a command reads and writes: the output rule every writer applies ([`output`]), the
//! checks of input files ([`input`]) and the temporaries that must not outlive the command
//! ([`temporaries`]).

pub mod input;
pub mod output;
pub mod temporaries;

pub use crate::image::atomic::write_atomically;
pub use output::{check_output, check_outputs, Format};

//! Progressive-refinement solver pieces: the unshot-power heap.

pub mod heap;

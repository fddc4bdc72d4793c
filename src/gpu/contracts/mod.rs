//! Rust and GLSL both spell out the GPU's layouts, bindings and shared
//! constants; these tests check one against the other so neither drifts.
//!
//! `tests.rs` holds Rust's side of every contract (the mirrored structs,
//! each pass's bindings and push constants, the vertex attributes, the
//! workgroup sizes, the shared constants) and checks it against the
//! committed SPIR-V (`spirv/`, read by `spirv.rs`). Constants are read from
//! the GLSL source instead: glslang folds `const` and `#define` values into
//! unnamed SPIR-V constants (`tests/it/shaders.rs` keeps `spirv/` and
//! `glsl/` in step). A new shared struct, pass or constant goes in its
//! table there; a laid-out struct or a shader missing from them fails.

mod spirv;
mod tests;

//! The committed SPIR-V modules, embedded by `build.rs`.

include!(concat!(env!("OUT_DIR"), "/shaders.rs"));

/// Decodes embedded SPIR-V into aligned words (`ash::util::read_spv`).
pub fn words(bytes: &[u8]) -> std::io::Result<Vec<u32>> {
    ash::util::read_spv(&mut std::io::Cursor::new(bytes))
}

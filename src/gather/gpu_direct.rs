//! The emitters' direct light at gather points on the GPU
//! (`gpu::rays::SourceGatherPass`: a compute pass over a BVH in storage
//! buffers), while the CPU gathers the reflected light.
//!
//! Why: direct light is where the gather's rays concentrate (256 to a
//! light from every point in a penumbra) and the work is the same for
//! every point: a fixed, short list of sources, many rays each, which is
//! what a GPU does well. The CPU keeps the irregular part (the
//! hierarchy, clusters, the reflected cache). On lavapipe the GPU pass is
//! 3-6x slower than the CPU's own rays (`cargo bench --bench gpu_rays`),
//! so `--tune direct_light auto` keeps the CPU there.
//!
//! Each emitting patch is one source (its polygon, its mean radiosity,
//! [`VertexGather::emitter_rays`] rays with the CPU's early out), where
//! the CPU opens a light near the point into its parts: both are
//! unbiased estimates of the same integral (the exact form factor times
//! the kernel-weighted visible share), and
//! `tests/it/gpu_rays.rs` checks the pass against the CPU.

use std::sync::{Arc, Mutex};

use glam::Vec3;

use super::{Frame, Source, VertexGather};
use crate::error::Result;
use crate::gpu::rays::{GatherPoint, GatherSource, GpuBvh, SourceGatherPass, MAX_SOURCE_CORNERS};
use crate::gpu::Device;
use crate::solve::hierarchy::ShooterTree;

/// Where one of the final gather's GPU ray passes runs: the emitters'
/// direct light ([`VertexGather::direct_light`](super::VertexGather::direct_light)) or the pixels'
/// first-hit rays ([`VertexGather::ray_device`](super::VertexGather::ray_device)).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DirectLight {
    /// On the GPU when the device is one, on the CPU when the device is
    /// the CPU itself (lavapipe: there both passes are slower than the
    /// CPU's own rays, `cargo bench --bench gpu_rays`).
    Auto,
    Cpu,
    Gpu,
}

impl DirectLight {
    /// Whether the work this choice governs runs on `device`'s GPU.
    pub fn on_gpu(self, device: &Device) -> bool {
        match self {
            DirectLight::Auto => !device.is_cpu(),
            DirectLight::Cpu => false,
            DirectLight::Gpu => true,
        }
    }
}

/// Seeds the GPU's rays (with each point's number as its stream).
const SEED: u32 = 0x9a7e;

/// The pass, and the emitters as its sources.
pub(super) struct GpuDirect {
    /// `None` after a failure: the CPU then gathers the direct light too.
    pass: Mutex<Option<SourceGatherPass>>,
    emitters: Vec<GatherSource>,
    /// Why the GPU stopped, for the run's warnings.
    pub(super) failure: Mutex<Option<String>>,
}

impl GpuDirect {
    /// The pass over `bvh` (`gpu_rays::upload_bvh`), with no sources yet.
    pub(super) fn new(device: &Arc<Device>, bvh: Arc<GpuBvh>) -> Result<Self> {
        Ok(GpuDirect {
            pass: Mutex::new(Some(SourceGatherPass::new(device, bvh)?)),
            emitters: Vec::new(),
            failure: Mutex::new(None),
        })
    }

    /// Takes the emitting patches (the roots `roots` of `tree`) with their
    /// light in `sources` as the pass's sources; false when one cannot be
    /// (too many corners).
    pub(super) fn set_emitters(
        &mut self,
        tree: &ShooterTree,
        roots: &[u32],
        sources: &[Source],
        settings: &VertexGather,
    ) -> bool {
        self.emitters.clear();
        for &n in roots {
            let (node, src) = (&tree.nodes[n as usize], &sources[n as usize]);
            if !src.emits {
                continue;
            }
            if !(3..=MAX_SOURCE_CORNERS).contains(&node.polygon.len()) {
                return false;
            }
            let corners: Vec<[f32; 3]> = node.polygon.iter().map(|c| c.to_array()).collect();
            self.emitters.push(GatherSource::new(
                &corners,
                node.normal.to_array(),
                node.patch,
                src.radiosity.to_array(),
                settings.emitter_rays.max(1) as u32,
                true,
            ));
        }
        true
    }

    /// The direct light `sum B F V` over the emitters at `frames`, which
    /// are points `first..` of the call (their numbers seed the rays), at
    /// most `rays` rays a light; `None` when the GPU has failed (now or
    /// before).
    pub(super) fn direct(&self, first: usize, frames: &[Frame], rays: usize) -> Option<Vec<Vec3>> {
        let mut pass = self.pass.lock().unwrap_or_else(|e| e.into_inner());
        let gpu = pass.as_mut()?;
        let points: Vec<GatherPoint> = frames
            .iter()
            .enumerate()
            .map(|(i, &(p, n, patch))| GatherPoint {
                p: p.to_array(),
                patch,
                n: n.to_array(),
                stream: (first + i) as u32,
            })
            .collect();
        let emitters: Vec<GatherSource> = self
            .emitters
            .iter()
            .map(|e| GatherSource {
                rays: e.rays.min(rays.max(1) as u32),
                ..*e
            })
            .collect();
        match gpu.gather(&points, &emitters, SEED) {
            Ok(values) => Some(values.into_iter().map(Vec3::from).collect()),
            Err(e) => {
                *self.failure.lock().unwrap_or_else(|e| e.into_inner()) = Some(format!(
                    "the GPU's direct-light pass failed ({e}); the CPU gathered the rest"
                ));
                *pass = None;
                None
            }
        }
    }
}

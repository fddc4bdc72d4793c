//! The final gather's first-hit rays on the GPU (`gpu::rays::FirstHitPass`:
//! a compute pass over a BVH in storage buffers): the hemisphere rays of
//! a scene of small patches ([`hemisphere_rays`](super::hemisphere_rays))
//! and the image's camera rays (`gather::pixels`).
//!
//! Why one pass for both: each is a list of rays whose nearest hit the
//! CPU then reads, the same query over the same BVH. Where the pass
//! fails mid-gather it is dropped and the CPU traces the rest.

use std::sync::{Arc, Mutex};

use glam::Vec3;

use crate::error::Result;
use crate::formfactor::raytrace::flat_bvh::FlatBvh;
use crate::gpu::rays::{FirstHitPass, GpuBvh, Hit, Ray};
use crate::gpu::Device;
use crate::scene::Scene;

use super::FinalGather;

/// `scene`'s flat BVH (the CPU's triangles, binary, depth first) in
/// storage buffers on `device`: what the GPU's ray passes traverse.
pub(super) fn upload_bvh(device: &Arc<Device>, scene: &Scene) -> Result<Arc<GpuBvh>> {
    let flat = FlatBvh::new(scene);
    let bvh = GpuBvh::new(device, &flat.nodes, &flat.triangles, flat.eps)?;
    Ok(Arc::new(bvh))
}

/// The pass (`None` after a failure).
pub(super) struct GpuRays {
    pass: Mutex<Option<FirstHitPass>>,
}

impl GpuRays {
    /// The pass over `bvh` ([`upload_bvh`]).
    pub(super) fn new(device: &Arc<Device>, bvh: Arc<GpuBvh>) -> Result<Self> {
        Ok(GpuRays {
            pass: Mutex::new(Some(FirstHitPass::new(device, bvh)?)),
        })
    }

    /// The nearest patch each ray meets, `(t, patch)`; `None` when the GPU
    /// has failed (now: the pass is then dropped, or before).
    pub(super) fn first_hits(&self, rays: &[Ray]) -> Option<Vec<Option<(f32, u32)>>> {
        let mut guard = self.pass.lock().ok()?;
        match guard.as_mut()?.first_hits(rays) {
            Ok(hits) => Some(hits.iter().map(Hit::met).collect()),
            Err(_) => {
                *guard = None;
                None
            }
        }
    }

    /// Whether the pass still works.
    pub(super) fn working(&self) -> bool {
        self.pass.lock().is_ok_and(|p| p.is_some())
    }

    /// Rays the pass has traced so far.
    pub(super) fn traced(&self) -> u64 {
        let pass = self.pass.lock();
        pass.ok()
            .and_then(|p| p.as_ref().map(|p| p.traced))
            .unwrap_or(0)
    }
}

/// Where the final gather's first-hit rays go.
impl FinalGather<'_> {
    /// Whether the hemisphere rays are traced on the GPU (and the GPU has
    /// not failed at them).
    pub fn hemisphere_rays_on_gpu(&self) -> bool {
        self.gather.hemisphere_rays_on_gpu()
    }

    /// Whether the first-hit rays (hemisphere and camera rays) are traced
    /// on the GPU (`ray_device`), and the GPU has not failed at them.
    pub fn rays_on_gpu(&self) -> bool {
        self.gather.gpu_rays.as_ref().is_some_and(GpuRays::working)
    }

    /// The first-hit rays the GPU has traced so far.
    pub fn rays_traced_on_gpu(&self) -> u64 {
        self.gather.gpu_rays.as_ref().map_or(0, GpuRays::traced)
    }

    /// The nearest patch each ray from `origin` along `directions` meets,
    /// `(t, patch)`, traced on the GPU where the first-hit rays are
    /// ([`VertexGather::ray_device`]); `None` where they are not, or the
    /// GPU fails (the CPU then traces them).
    pub fn first_hits_on_gpu(
        &self,
        origin: Vec3,
        directions: &[Vec3],
    ) -> Option<Vec<Option<(f32, u32)>>> {
        let gpu = self.gather.gpu_rays.as_ref()?;
        let ray = |d: &Vec3| Ray {
            a: origin.to_array(),
            skip: u32::MAX,
            d: d.to_array(),
            tmin: 0.0,
        };
        gpu.first_hits(&directions.iter().map(ray).collect::<Vec<_>>())
    }
}

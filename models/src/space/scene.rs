//! From the environment's [`Scene`] (OSI ground truth → meshes, instances) to a [`Space`].
//!
//! Scene mesh `i` becomes [`MeshHandle`]`(i)`; scene meshes are only ever appended, so
//! [`Space::sync_scene`] builds BLASes for the new ones and rebuilds the top level. A rebuilt static
//! world (new `Scene::static_revision`, e.g. after the origin moved) needs a new space.

use super::{InstanceDesc, MeshHandle, Space, SpaceBuilder, SpaceError};
use crate::environment::scene::Scene;

impl SpaceBuilder {
    /// The space of a scene: its static world, one BLAS per scene mesh, its instances. Any geometry
    /// already added to this builder is kept (added before the scene's).
    pub fn build_scene(mut self, scene: &Scene) -> Result<Space, SpaceError> {
        self = self.origin(scene.origin);
        self.add_static(&scene.static_world.mesh, &scene.static_world.part_material)?;
        let first = self.mesh_count();
        for m in &scene.meshes {
            self.add_mesh(&m.mesh, &m.part_material)?;
        }
        let mut space = self.build();
        space.scene_revision = Some(scene.static_revision);
        space.scene_mesh_base = first;
        space.set_instances(&scene_instances(scene, first))?;
        Ok(space)
    }
}

impl Space {
    /// Bring the space to the scene's current state: BLASes for meshes the scene added since, the
    /// instances' poses and velocities (top-level rebuild). Returns `Ok(false)` and changes nothing
    /// when the scene's static world was rebuilt since this space was built from it (or the space
    /// was not built from a scene): build a new space with [`SpaceBuilder::build_scene`] then.
    pub fn sync_scene(&mut self, scene: &Scene) -> Result<bool, SpaceError> {
        if self.scene_revision != Some(scene.static_revision) || self.origin() != scene.origin {
            return Ok(false);
        }
        let known = self.meshes.len() - self.scene_mesh_base as usize;
        for m in scene.meshes.iter().skip(known) {
            self.add_mesh(&m.mesh, &m.part_material)?;
        }
        self.set_instances(&scene_instances(scene, self.scene_mesh_base))?;
        Ok(true)
    }
}

/// The scene's instances as space instances (scene mesh `i` → `MeshHandle(base + i)`).
fn scene_instances(scene: &Scene, base: u32) -> Vec<InstanceDesc> {
    scene
        .instances
        .iter()
        .map(|i| InstanceDesc {
            object_id: i.object_id,
            mesh: MeshHandle(base + i.mesh as u32),
            pose: i.pose_local,
            linear_velocity: i.velocity_m_s,
            angular_velocity: i.angular_velocity_rad_s,
        })
        .collect()
}

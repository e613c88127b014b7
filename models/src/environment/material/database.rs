//! The materials database: every material of a scene by [`MaterialId`] and name, the shipped
//! starter set (`models/resources/materials.json`), loading and extending from JSON files, parametric
//! `lambertian_<NN>` materials, and the dry ↔ wet variant mapping.

use std::collections::HashMap;
use std::path::Path;
use std::sync::OnceLock;

use super::{Band, Material, MaterialEffects, MaterialError, MaterialId, parse, parse_lambertian};

/// Label of the built-in file in error messages.
const BUILTIN_LABEL: &str = "materials.json (builtin)";
/// The built-in starter set.
const BUILTIN_JSON: &str = include_str!("../../../resources/materials.json");

/// All materials of a scene.
#[derive(Debug, Clone, Default)]
pub struct MaterialDb {
    pub(super) materials: Vec<Material>,
    index: HashMap<String, MaterialId>,
    wet: HashMap<MaterialId, MaterialId>,
    dry: HashMap<MaterialId, MaterialId>,
}

impl MaterialDb {
    /// The shipped starter set (`models/resources/materials.json`).
    pub fn builtin() -> MaterialDb {
        static BUILTIN: OnceLock<MaterialDb> = OnceLock::new();
        BUILTIN
            .get_or_init(|| {
                let mut db = MaterialDb::default();
                if let Err(e) = db.extend_from_json_str(BUILTIN_JSON, BUILTIN_LABEL) {
                    panic!("built-in materials database is invalid: {e}");
                }
                db
            })
            .clone()
    }

    /// A database from a JSON document (errors are labelled `<string>`).
    pub fn from_json_str(text: &str) -> Result<MaterialDb, MaterialError> {
        let mut db = MaterialDb::default();
        db.extend_from_json_str(text, "<string>")?;
        Ok(db)
    }

    /// A database from a JSON file.
    pub fn from_json_file(path: impl AsRef<Path>) -> Result<MaterialDb, MaterialError> {
        let mut db = MaterialDb::default();
        db.extend_from_json_file(path)?;
        Ok(db)
    }

    /// Add the materials of a JSON file; a material of the same name is replaced (keeping its id), and
    /// wet variants derived from a replaced dry material are derived again. Returns the ids defined by
    /// the file, in file order.
    pub fn extend_from_json_file(
        &mut self,
        path: impl AsRef<Path>,
    ) -> Result<Vec<MaterialId>, MaterialError> {
        let path = path.as_ref();
        let label = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| MaterialError::Io {
            file: label.clone(),
            message: e.to_string(),
        })?;
        self.extend_from_json_str(&text, &label)
    }

    /// [`MaterialDb::extend_from_json_file`] on a string; `label` names it in errors. On error the
    /// database is unchanged.
    pub fn extend_from_json_str(
        &mut self,
        text: &str,
        label: &str,
    ) -> Result<Vec<MaterialId>, MaterialError> {
        let mut next = self.clone();
        let ids = parse::load(&mut next, text, label)?;
        *self = next;
        Ok(ids)
    }

    /// Id of a material already in the database.
    pub fn id(&self, name: &str) -> Option<MaterialId> {
        self.index.get(name).copied()
    }

    /// Id of a material, creating parametric ones (`lambertian_<percent>`) on first use.
    pub fn resolve(&mut self, name: &str) -> Result<MaterialId, MaterialError> {
        if let Some(id) = self.id(name) {
            return Ok(id);
        }
        match parse_lambertian(name) {
            Some(rho) => Ok(self.insert(Material::lambertian(name, rho))),
            None => Err(MaterialError::Unknown(name.to_owned())),
        }
    }

    /// Name of a material.
    pub fn name(&self, id: MaterialId) -> &str {
        &self.materials[id.0 as usize].name
    }

    /// The material of an id (panics on an id of another database).
    pub fn get(&self, id: MaterialId) -> &Material {
        &self.materials[id.0 as usize]
    }

    /// The material of a name, if present.
    pub fn by_name(&self, name: &str) -> Option<&Material> {
        self.id(name).map(|id| self.get(id))
    }

    /// Number of materials.
    pub fn len(&self) -> usize {
        self.materials.len()
    }

    /// Whether the database is empty.
    pub fn is_empty(&self) -> bool {
        self.materials.is_empty()
    }

    /// All materials with their ids, in id order.
    pub fn iter(&self) -> impl Iterator<Item = (MaterialId, &Material)> {
        self.materials
            .iter()
            .enumerate()
            .map(|(i, m)| (MaterialId(i as u32), m))
    }

    /// Add a material (e.g. one built with [`Material::with_water_film`]); a duplicate name or an
    /// unknown `wet_of` is an error.
    pub fn add(&mut self, material: Material) -> Result<MaterialId, MaterialError> {
        if self.index.contains_key(&material.name) {
            return Err(MaterialError::Invalid(format!(
                "duplicate material `{}`",
                material.name
            )));
        }
        if let Some(dry) = &material.wet_of {
            let dry_id = self
                .id(dry)
                .ok_or_else(|| MaterialError::Unknown(dry.clone()))?;
            if let Some(&other) = self.wet.get(&dry_id) {
                return Err(MaterialError::Invalid(format!(
                    "`{}` is already the wet variant of `{dry}`",
                    self.name(other)
                )));
            }
        }
        Ok(self.insert(material))
    }

    /// Insert or replace without checks; maintains the indices.
    pub(super) fn insert(&mut self, material: Material) -> MaterialId {
        let id = match self.index.get(&material.name) {
            Some(&id) => {
                self.materials[id.0 as usize] = material;
                id
            }
            None => {
                let id = MaterialId(self.materials.len() as u32);
                self.index.insert(material.name.clone(), id);
                self.materials.push(material);
                id
            }
        };
        self.rebuild_wet_index();
        id
    }

    fn rebuild_wet_index(&mut self) {
        self.wet.clear();
        self.dry.clear();
        for (i, m) in self.materials.iter().enumerate() {
            if let Some(dry) = m.wet_of.as_ref().and_then(|d| self.index.get(d)) {
                self.wet.insert(*dry, MaterialId(i as u32));
                self.dry.insert(MaterialId(i as u32), *dry);
            }
        }
    }

    /// The wet variant of a material (`asphalt_dry` → `asphalt_wet`, ...); a wet material is its own
    /// wet variant; `None` for materials without one.
    pub fn wet_variant(&self, id: MaterialId) -> Option<MaterialId> {
        if self.dry.contains_key(&id) {
            Some(id)
        } else {
            self.wet.get(&id).copied()
        }
    }

    /// The dry material of a wet variant (`None` for dry materials).
    pub fn dry_variant(&self, id: MaterialId) -> Option<MaterialId> {
        self.dry.get(&id).copied()
    }

    /// The material to use for a surface: its wet variant when `wet` and `env.wet_surfaces` is on,
    /// else the material itself.
    pub fn surface(&self, id: MaterialId, wet: bool, fx: &MaterialEffects) -> MaterialId {
        if wet && fx.wet_surfaces {
            self.wet_variant(id).unwrap_or(id)
        } else {
            id
        }
    }

    /// Optical transmittance of a material at `cos θ` (0 for opaque materials).
    pub fn transmittance(&self, id: MaterialId, band: Band, cos_theta: f64) -> f64 {
        self.get(id).transmittance(band, cos_theta)
    }
}

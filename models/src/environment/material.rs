//! The materials database. To be written; the API below is the contract other modules use.

/// Index of a material in a [`MaterialDb`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct MaterialId(pub u32);

/// Errors of material lookup and loading.
#[derive(Debug, thiserror::Error)]
pub enum MaterialError {
    #[error("unknown material `{0}`")]
    Unknown(String),
    #[error("materials database: {0}")]
    Invalid(String),
}

/// All materials of a scene.
#[derive(Debug, Clone, Default)]
pub struct MaterialDb {
    names: Vec<String>,
}

impl MaterialDb {
    /// The shipped starter set (`models/resources/materials.json`).
    pub fn builtin() -> MaterialDb {
        MaterialDb::default()
    }

    /// Id of a material already in the database.
    pub fn id(&self, name: &str) -> Option<MaterialId> {
        self.names.iter().position(|n| n == name).map(|i| MaterialId(i as u32))
    }

    /// Id of a material, creating parametric ones (`lambertian_<percent>`) on first use.
    pub fn resolve(&mut self, name: &str) -> Result<MaterialId, MaterialError> {
        self.id(name).ok_or_else(|| MaterialError::Unknown(name.to_owned()))
    }

    /// Name of a material.
    pub fn name(&self, id: MaterialId) -> &str {
        &self.names[id.0 as usize]
    }
}

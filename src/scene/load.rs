//! Scene loaders. STUB.
use super::Scene;
use std::path::Path;
#[derive(Debug, thiserror::Error)]
pub enum SceneError { #[error("{0}")] Other(String) }
pub fn load_scene(_path: &Path) -> Result<Scene, SceneError> { todo!() }

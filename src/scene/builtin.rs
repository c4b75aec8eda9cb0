//! The built-in default scene. STUB.
use super::Scene;
pub fn builtin_scene() -> Scene { todo!() }

//! Renderer. STUB

//! Reference renderer. STUB

//! GPU context. STUB

//! Error metrics. STUB

//! Writing frames: OBJ sequences, PC2 point caches and binary glTF.
//!
//! Vertices are always in grid order (index `i + j * nu`), the contract
//! every consumer of drapery's output relies on.

mod decimal;
mod glb;
mod obj;
mod pc2;

pub use glb::write_glb;
pub use obj::write_obj;
pub use pc2::Pc2Writer;

//! Writing frames: OBJ sequences and PC2 point caches.
//!
//! Vertices are always in grid order (index `i + j * nu`), the contract
//! every consumer of drapery's output relies on.

mod obj;
mod pc2;

pub use obj::write_obj;
pub use pc2::Pc2Writer;

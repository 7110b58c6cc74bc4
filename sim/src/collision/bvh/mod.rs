//! Bounding-volume hierarchies of axis-aligned boxes: the tree and its
//! queries (`tree`), values folded up it (`fold`), and its self-descent
//! cut into seeds that the team shares (`self_pairs`).

mod fold;
mod self_pairs;
mod tree;

pub use self_pairs::Task;
pub use tree::Bvh;

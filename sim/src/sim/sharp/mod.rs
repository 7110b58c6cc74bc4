//! The sharp-feature stage of a step: no cloth edge passes through an
//! obstacle's edge and no obstacle corner through a cloth triangle.
//!
//! method.md §3 tests particles only, and so widens the offset until a
//! cloth edge whose ends rest on the offset surface cannot reach an
//! obstacle edge between them: 0.41 spacings for a box, which left the
//! table-drape cloth floating 11.1 mm above its table. Here the corners
//! and edges (`collision::Features`) are tested against the cloth's edges
//! and triangles themselves, edge–edge and vertex–face, as the cloth's
//! self-collision tests its own (Bridson, Fedkiw & Anderson 2002), and
//! the offset of a shape whose features are tested shrinks to its margin.
//!
//! | part | does | file |
//! | --- | --- | --- |
//! | features | each obstacle's corners at the step's start and end poses, their swept boxes grown by what the cloth keeps from them | `pairs` |
//! | pairs | cloth edges against feature edges, feature corners against cloth triangles: each cloth element's swept box against the features' small hierarchies | `pairs` |
//! | couplings | before the solve: a pair closer than `KEEP` of the offset at the step's start becomes a `solver::Coupling`, a stiff one-sided spring in `A` that carries the cloth's load (a chord over a table's corner holds up the cloth hanging from it) | `stage` |
//! | sweeps | after the solve: a pair that ends closer than `HARD` × `KEEP` of the offset, or meets during the step (the continuous test), moves its cloth particles out by inverse mass; `SWEEPS` times over every pair | `correct` |
//! | freeze | the cloth particles of pairs that still meet move with the obstacle for the step (a rigid motion shared with the obstacle cannot bring them together: the start had no crossing), until none meets | `correct` |
//! | release | a particle moved by more than `LIFT_OFF` of the offset loses its contact, so the next step does not pull it back | `stage` |
//!
//! The obstacle is infinitely heavy: only the cloth moves. The part of a
//! correction that stops an approach becomes velocity (an inelastic
//! contact); the rest only moves the cloth out. The correction runs after
//! the self-collision stage, as the last word on where the step ends; it
//! alone (without couplings) fought the solve wherever the cloth hangs
//! from an edge: 18–31 % stretch at table-drape's corners.

mod correct;
mod pairs;
mod stage;

pub use stage::{KEEP, SharpReport, SharpStage};

//! A hierarchy against itself: every pair of its primitives whose boxes
//! overlap, once, in a fixed order; with nodes skipped whose primitives a
//! caller knows cannot meet each other; and cut into seeds, subtrees of
//! the descent whose pairs, gathered one after another in seed order, are
//! exactly the whole descent's in its order, so that they can be gathered
//! on several threads with the same result.

use super::Bvh;

/// A task of the descent: a node against itself (`a == b`) or two nodes.
pub type Task = (u32, u32);

impl Bvh {
    /// Calls `f(i, j)` once for every pair `i != j` of this hierarchy's
    /// primitives whose boxes overlap (in either order).
    pub fn self_pairs(&self, f: impl FnMut(usize, usize)) {
        self.self_pairs_skipping(|_| false, f);
    }

    /// [`Bvh::self_pairs`] without the pairs that lie wholly under a node
    /// for which `skip(node)` holds (nodes numbered as by
    /// [`Bvh::fold_up`]): for a caller that knows a subtree's primitives
    /// cannot interact with each other.
    pub fn self_pairs_skipping(
        &self,
        mut skip: impl FnMut(usize) -> bool,
        mut f: impl FnMut(usize, usize),
    ) {
        if self.nodes.is_empty() {
            return;
        }
        self.self_pairs_under((0, 0), &mut skip, &mut Vec::new(), &mut f);
    }

    /// The first tasks of [`Bvh::self_pairs_skipping`]'s descent, in the
    /// order it finishes them, into `seeds`: inner tasks are opened (as the
    /// descent would, `skip` included) until there are `target` tasks, so
    /// [`Bvh::self_pairs_under`] of each seed in turn calls `f` exactly as
    /// the whole descent does. Opening a task calls nothing but `skip`.
    pub fn self_pair_seeds(
        &self,
        target: usize,
        mut skip: impl FnMut(usize) -> bool,
        seeds: &mut Vec<Task>,
    ) {
        seeds.clear();
        if self.nodes.is_empty() {
            return;
        }
        let mut stack = vec![(0u32, 0u32)];
        while let Some(task) = stack.pop() {
            let opens = {
                let (a, b) = task;
                self.nodes[a as usize].count == 0 || (a != b && self.nodes[b as usize].count == 0)
            };
            if opens && seeds.len() + stack.len() + 1 < target {
                // Pushes its children, or nothing: no pairs (both leaves
                // would be needed for those).
                self.visit(task, &mut skip, &mut stack, &mut |_, _| {});
            } else {
                seeds.push(task);
            }
        }
    }

    /// The descent from one task (a seed, or the root `(0, 0)`), `stack` as
    /// scratch.
    pub fn self_pairs_under(
        &self,
        seed: Task,
        skip: &mut impl FnMut(usize) -> bool,
        stack: &mut Vec<Task>,
        f: &mut impl FnMut(usize, usize),
    ) {
        stack.clear();
        stack.push(seed);
        while let Some(task) = stack.pop() {
            self.visit(task, skip, stack, f);
        }
    }

    /// One task of the descent: a node against another descends both; a
    /// node against itself is skipped, opened into its children's three
    /// tasks, or (a leaf) tested pair by pair.
    fn visit(
        &self,
        (a, b): Task,
        skip: &mut impl FnMut(usize) -> bool,
        stack: &mut Vec<Task>,
        f: &mut impl FnMut(usize, usize),
    ) {
        if a != b {
            self.descend(self, a, b, stack, f);
            return;
        }
        if skip(a as usize) {
            return;
        }
        let na = &self.nodes[a as usize];
        if na.count == 0 {
            let (l, r) = (a + 1, na.start);
            stack.extend([(l, l), (r, r), (l, r)]);
            return;
        }
        let leaf = self.leaf(na);
        for (k, &i) in leaf.iter().enumerate() {
            for &j in &leaf[k + 1..] {
                if self.boxes[i as usize].overlaps(&self.boxes[j as usize]) {
                    f(i as usize, j as usize);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::tree::tests::random_boxes;
    use super::*;
    use rand::{SeedableRng, rngs::StdRng};

    /// Seeds gathered in turn give the whole descent's pairs in its order,
    /// whatever the target, with nodes skipped or not; `skip` is asked
    /// about each node once.
    #[test]
    fn seeds_in_turn_are_the_whole_descent() {
        let mut rng = StdRng::seed_from_u64(23);
        let boxes: Vec<_> = random_boxes(&mut rng, 400)
            .iter()
            .map(|b| b.grown(0.1))
            .collect();
        let bvh = Bvh::build(&boxes);
        for skipping in [false, true] {
            let skip = |k: usize| skipping && k % 5 == 3;
            let mut asked = vec![0; bvh.nodes.len()];
            let mut whole = Vec::new();
            bvh.self_pairs_skipping(
                |k| {
                    asked[k] += 1;
                    skip(k)
                },
                |i, j| whole.push((i, j)),
            );
            assert!(whole.len() > 500, "{} pairs", whole.len());
            assert!(asked.iter().all(|&n| n <= 1));
            for target in [1, 2, 7, 64, 1000] {
                let mut asked_again = vec![0; bvh.nodes.len()];
                let mut seeds = Vec::new();
                bvh.self_pair_seeds(
                    target,
                    |k| {
                        asked_again[k] += 1;
                        skip(k)
                    },
                    &mut seeds,
                );
                assert!(seeds.len() <= target.max(1) + 3, "{} seeds", seeds.len());
                let mut got = Vec::new();
                let mut stack = Vec::new();
                for &s in &seeds {
                    bvh.self_pairs_under(
                        s,
                        &mut |k| {
                            asked_again[k] += 1;
                            skip(k)
                        },
                        &mut stack,
                        &mut |i, j| got.push((i, j)),
                    );
                }
                assert_eq!(got, whole, "target {target}, skipping {skipping}");
                assert_eq!(asked_again, asked);
            }
        }
    }

    /// Skipping a node drops exactly the pairs with both primitives under
    /// it; a fold up the tree sees every primitive once.
    #[test]
    fn skipped_nodes_drop_exactly_their_inner_pairs() {
        let mut rng = StdRng::seed_from_u64(17);
        let boxes = random_boxes(&mut rng, 300);
        let bvh = Bvh::build(&boxes);
        let mut under: Vec<Vec<usize>> = Vec::new();
        let mut counts = Vec::new();
        bvh.fold_up(&mut counts, <[u32]>::len, |a, b| a + b);
        assert_eq!(counts[0], 300);
        // The primitives under each node, by walking it.
        for k in 0..bvh.nodes.len() {
            let mut stack = vec![k];
            let mut prims = Vec::new();
            while let Some(n) = stack.pop() {
                let node = &bvh.nodes[n];
                if node.count > 0 {
                    prims.extend(bvh.leaf(node).iter().map(|&i| i as usize));
                } else {
                    stack.extend([n + 1, node.start as usize]);
                }
            }
            assert_eq!(prims.len(), counts[k]);
            under.push(prims);
        }
        let pairs = |skip: &dyn Fn(usize) -> bool| {
            let mut found = Vec::new();
            bvh.self_pairs_skipping(skip, |i, j| found.push((i.min(j), i.max(j))));
            found.sort_unstable();
            found
        };
        let all = pairs(&|_| false);
        let mut with_inner_pairs = 0;
        for skipped in (0..bvh.nodes.len()).step_by(7) {
            let inside = &under[skipped];
            let want: Vec<_> = all
                .iter()
                .copied()
                .filter(|(i, j)| !(inside.contains(i) && inside.contains(j)))
                .collect();
            with_inner_pairs += usize::from(want.len() < all.len());
            assert_eq!(pairs(&|k| k == skipped), want, "node {skipped}");
        }
        assert!(
            with_inner_pairs >= 5,
            "{with_inner_pairs} nodes had inner pairs"
        );
    }
}

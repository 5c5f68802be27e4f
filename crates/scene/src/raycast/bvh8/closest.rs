//! Closest-hit traversal of [`Bvh8`]: one ray at a time, or a batch of
//! rays walked together so their node loads overlap (the any-hit walk, a
//! plain loop, stays with the tree in `bvh8.rs`).

use glam::{Vec3A, Vec4};

use super::{Bvh8, Bvh8Hit, Bvh8Ray, SMALL_STACK};

impl Bvh8 {
    /// Closest hit with t < the ray's `t_max`.
    pub(in crate::raycast) fn closest_hit(&self, ray: &Bvh8Ray) -> Option<Bvh8Hit> {
        if self.stack_len() <= SMALL_STACK {
            self.closest_hit_in(ray, &mut [(0, 0.0); SMALL_STACK])
        } else {
            self.closest_hit_in(ray, &mut vec![(0, 0.0); self.stack_len()])
        }
    }

    /// [`Bvh8::closest_hit`] with a stack of at least [`Bvh8::stack_len`].
    fn closest_hit_in(&self, ray: &Bvh8Ray, stack: &mut [(u32, f32)]) -> Option<Bvh8Hit> {
        if self.nodes.is_empty() {
            return None;
        }
        let mut walk = ClosestWalk::new(ray);
        while self.closest_step(ray, &mut walk, stack) {}
        self.closest_result(ray, &walk)
    }

    /// [`Bvh8::closest_hit`] of every ray of `rays`, passed to `emit` with
    /// the ray's index (in no particular order).
    ///
    /// # Performance
    /// A ray's walk waits on one cache miss per node once the tree is larger
    /// than L2, and each node's address depends on the node before. So
    /// [`BATCH_LANES`] rays are walked together, one node each in turn:
    /// their node loads are independent and overlap. A visit that enters
    /// leaves takes two turns: the first finds the leaves and prefetches
    /// their packets, the second tests them (the same operations, in the
    /// same order, as one [`Bvh8::closest_step`]).
    pub(in crate::raycast) fn closest_hits(
        &self,
        rays: &[Bvh8Ray],
        mut emit: impl FnMut(usize, Option<Bvh8Hit>),
    ) {
        if self.nodes.is_empty() || self.stack_len() > SMALL_STACK {
            for (i, ray) in rays.iter().enumerate() {
                emit(i, self.closest_hit(ray));
            }
            return;
        }
        let mut stacks = [[(0, 0.0); SMALL_STACK]; BATCH_LANES];
        let mut walks: [ClosestWalk; BATCH_LANES] =
            std::array::from_fn(|_| ClosestWalk::new(&rays[0]));
        let mut ids = [usize::MAX; BATCH_LANES];
        let mut next = 0;
        for (lane, id) in ids.iter_mut().enumerate().take(rays.len()) {
            walks[lane] = ClosestWalk::new(&rays[lane]);
            *id = lane;
            next += 1;
        }
        let mut active = next;
        while active > 0 {
            for lane in 0..BATCH_LANES {
                let id = ids[lane];
                if id == usize::MAX {
                    continue;
                }
                let ray = &rays[id];
                let walk = &mut walks[lane];
                if !walk.entered {
                    let lanes = self.closest_enter(ray, walk);
                    if lanes != 0 {
                        self.prefetch_packets(self.nodes[walk.cur].packet_base, lanes);
                        continue;
                    }
                }
                if self.closest_finish(ray, walk, &mut stacks[lane]) {
                    self.prefetch_node(walk.cur);
                    continue;
                }
                emit(id, self.closest_result(ray, &walks[lane]));
                if next < rays.len() {
                    walks[lane] = ClosestWalk::new(&rays[next]);
                    ids[lane] = next;
                    next += 1;
                } else {
                    ids[lane] = usize::MAX;
                    active -= 1;
                }
            }
        }
    }

    /// Starts loading node `index` into the cache: the other walks of a
    /// batch take their turns while it arrives.
    #[inline]
    fn prefetch_node(&self, index: usize) {
        #[cfg(target_arch = "x86_64")]
        {
            // A node spans four or five cache lines; this touches each.
            let node = &self.nodes[index];
            safe_arch::prefetch_t0(&node.planes[0][0]);
            safe_arch::prefetch_t0(&node.planes[2][0]);
            safe_arch::prefetch_t0(&node.planes[4][0]);
            safe_arch::prefetch_t0(&node.child[0]);
            safe_arch::prefetch_t0(&node.leaf_slots);
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = index;
    }

    /// Starts loading the leaf packets of `lanes` (as in [`Node::child`]),
    /// from packet `base` on.
    #[inline]
    fn prefetch_packets(&self, base: u32, mut lanes: u32) {
        #[cfg(target_arch = "x86_64")]
        {
            let mut packet = base as usize;
            while lanes != 0 {
                if lanes & 0xf != 0 {
                    // 160 bytes from a 16-byte boundary: three cache lines.
                    let p = &self.packets[packet];
                    safe_arch::prefetch_t0(&p.v0[0]);
                    safe_arch::prefetch_t0(&p.e1[1]);
                    safe_arch::prefetch_t0(&p.e2[2]);
                }
                lanes >>= 4;
                packet += 1;
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = (base, lanes);
    }

    /// The hit a finished walk found.
    fn closest_result(&self, ray: &Bvh8Ray, walk: &ClosestWalk) -> Option<Bvh8Hit> {
        walk.best
            .map(|(packet, lane)| self.hit_of(packet, lane, ray, walk.t_max))
    }

    /// Visits node `walk.cur` (tests its leaves, pushes its entered inner
    /// children) and moves `walk.cur` to the next node to visit; false when
    /// none is left. `stack` holds at least [`Bvh8::stack_len`] entries.
    #[inline]
    fn closest_step(
        &self,
        ray: &Bvh8Ray,
        walk: &mut ClosestWalk,
        stack: &mut [(u32, f32)],
    ) -> bool {
        self.closest_enter(ray, walk);
        self.closest_finish(ray, walk, stack)
    }

    /// First half of [`Bvh8::closest_step`]: the children of node
    /// `walk.cur` that the ray enters, kept in `walk`. Returns the lanes of
    /// the entered leaves (as in [`Node::child`]).
    #[inline]
    fn closest_enter(&self, ray: &Bvh8Ray, walk: &mut ClosestWalk) -> u32 {
        let node = &self.nodes[walk.cur];
        let (mask, t_near) = Self::enter(node, ray, walk.t_max);
        walk.mask = mask;
        walk.t_near = t_near;
        walk.entered = true;
        Self::leaf_lanes(node, mask & node.leaf_slots)
    }

    /// Second half of [`Bvh8::closest_step`], after [`Bvh8::closest_enter`].
    /// Always inlined: left as a call in the batch loop, it cost 3-4 % of
    /// the closest-hit time (docs/performance.md).
    #[allow(clippy::inline_always)]
    #[inline(always)]
    fn closest_finish(
        &self,
        ray: &Bvh8Ray,
        walk: &mut ClosestWalk,
        stack: &mut [(u32, f32)],
    ) -> bool {
        let node = &self.nodes[walk.cur];
        let mut t_max = walk.t_max;
        let mut top = walk.top;
        let (mask, t_near) = (walk.mask, walk.t_near);
        walk.entered = false;
        // Leaves first: a hit shortens the ray for the inner children.
        let mut lanes = Self::leaf_lanes(node, mask & node.leaf_slots);
        let mut packet = node.packet_base as usize;
        while lanes != 0 {
            if lanes & 0xf != 0 {
                let (t, hit) = Self::hit_packet(&self.packets[packet], ray, t_max);
                let mut hit = hit & lanes;
                while hit != 0 {
                    let lane = hit.trailing_zeros() as usize;
                    hit &= hit - 1;
                    if t[lane] < t_max {
                        t_max = t[lane];
                        walk.best = Some((packet, lane));
                    }
                }
            }
            lanes >>= 4;
            packet += 1;
        }
        walk.t_max = t_max;
        let t_near = [t_near[0].to_array(), t_near[1].to_array()];
        let dist = |slot: usize| t_near[slot / 4][slot % 4];
        // Push the entered inner children farthest first, so the nearest
        // pops first; then go on with the nearest pending one.
        let base = top;
        let mut inner = mask & !node.leaf_slots;
        while inner != 0 {
            let slot = inner.trailing_zeros() as usize;
            inner &= inner - 1;
            let item = (node.child[slot], dist(slot));
            if item.1 > t_max {
                continue;
            }
            // Insertion into the descending run stack[base..top].
            let mut k = top;
            while k > base && stack[k - 1].1 < item.1 {
                stack[k] = stack[k - 1];
                k -= 1;
            }
            stack[k] = item;
            top += 1;
        }
        loop {
            if top == 0 {
                walk.top = 0;
                return false;
            }
            top -= 1;
            if stack[top].1 <= t_max {
                walk.cur = stack[top].0 as usize;
                walk.top = top;
                return true;
            }
        }
    }

    fn hit_of(&self, packet: usize, lane: usize, ray: &Bvh8Ray, t: f32) -> Bvh8Hit {
        let p = &self.packets[packet];
        let get = |a: &[Vec4; 3]| Vec3A::new(a[0][lane], a[1][lane], a[2][lane]);
        let (v0, e1, e2) = (get(&p.v0), get(&p.e1), get(&p.e2));
        let o = Vec3A::new(ray.o[0].x, ray.o[1].x, ray.o[2].x);
        let d = Vec3A::new(ray.d[0].x, ray.d[1].x, ray.d[2].x);
        let r = d.cross(v0 - o);
        let det = e1.cross(e2).dot(d);
        Bvh8Hit {
            t,
            face: p.face[lane],
            u: r.dot(e2) / det,
            v: r.dot(e1) / det,
        }
    }
}

/// Rays walked together by the batch traversals ([`Bvh8::closest_hits`]).
const BATCH_LANES: usize = 8;

/// A closest-hit traversal between two node visits.
#[derive(Clone, Copy)]
struct ClosestWalk {
    /// The node to visit next.
    cur: usize,
    /// Pending nodes on the walk's stack.
    top: usize,
    /// The ray's end: its own, or the best hit's distance.
    t_max: f32,
    /// The best hit so far: packet and lane.
    best: Option<(usize, usize)>,
    /// Whether node `cur` is half visited: `mask` and `t_near` hold its
    /// entered children and their entry distances
    /// ([`Bvh8::closest_enter`]).
    entered: bool,
    mask: u32,
    t_near: [Vec4; 2],
}

impl ClosestWalk {
    /// At the root.
    fn new(ray: &Bvh8Ray) -> Self {
        ClosestWalk {
            cur: 0,
            top: 0,
            t_max: ray.t_max,
            best: None,
            entered: false,
            mask: 0,
            t_near: [Vec4::ZERO; 2],
        }
    }
}

//! The traversal side of [`super::RayCaster`]: an 8-wide BVH with `f32`
//! child boxes and 4-triangle leaf packets, decoded once from the tree
//! obvhs builds.
//!
//! obvhs's CWBVH stores child boxes as bytes relative to the parent and
//! converts them to floats at every node visit, and it tests a leaf's
//! triangles one by one through a callback. Profiles of our aerial rays put
//! most of the time there. This layout is what Embree uses on the CPU
//! instead: float boxes, tested four children per SSE instruction, children
//! visited nearest first, and the triangles of a leaf tested together, four
//! lanes of one Möller-Trumbore test. The boxes are the exact bounds of
//! each child's triangles (tighter than the quantised ones), so fewer
//! boxes are entered; the tree topology is obvhs's.
//!
//! Everything is safe code on glam's `Vec4` (SSE2 on x86-64, scalar
//! elsewhere).

use glam::{Vec3A, Vec4};
use obvhs::cwbvh::CwBvh;
use obvhs::triangle::Triangle;

mod closest;

/// Eight children: their boxes, four per `Vec4`, planes indexed as
/// [`Bvh8Ray::near`] describes, and what they hold.
#[derive(Clone, Copy)]
#[repr(C, align(16))]
struct Node {
    /// lo x, hi x, lo y, hi y, lo z, hi z; each as two halves of 4 children.
    planes: [[Vec4; 2]; 6],
    /// Inner child: its node index. Leaf child: the mask of its triangles'
    /// lanes in this node's packets (bit 4 p + l: lane l of packet
    /// `packet_base + p`).
    child: [u32; 8],
    /// First packet of this node's leaf triangles.
    packet_base: u32,
    /// Bit per child slot that is a leaf.
    leaf_slots: u32,
}

/// Up to four triangles in structure-of-arrays form, with obvhs's
/// `RtTriangle` conventions: e1 = v0 - v1, e2 = v2 - v0 (the normal
/// e1 x e2 is recomputed per test: cheaper than the memory it would take).
/// Unused lanes are all zero, a degenerate triangle no ray hits.
#[derive(Clone, Copy, Default)]
#[repr(C, align(16))]
struct Packet {
    v0: [Vec4; 3],
    e1: [Vec4; 3],
    e2: [Vec4; 3],
    /// Mesh face of each lane.
    face: [u32; 4],
}

/// A ray prepared for box and packet tests.
pub(super) struct Bvh8Ray {
    o: [Vec4; 3],
    d: [Vec4; 3],
    inv: [Vec4; 3],
    /// Plane index of the near plane per axis (lo if the direction is
    /// positive, hi otherwise); the far plane is `near ^ 1`.
    near: [usize; 3],
    /// Ray parameter range.
    t_min: f32,
    t_max: f32,
}

impl Bvh8Ray {
    /// A ray from `origin` in direction `dir` over `t_min..t_max`. Reciprocal
    /// directions as obvhs computes them (`Ray::new`), so a zero component
    /// gives a large finite slope instead of an infinity.
    pub(super) fn new(origin: Vec3A, dir: Vec3A, t_min: f32, t_max: f32) -> Self {
        let ray = obvhs::ray::Ray::new(origin, dir, t_min, t_max);
        let inv = ray.inv_direction;
        let near = |i: f32, axis: usize| 2 * axis + usize::from(i < 0.0);
        Bvh8Ray {
            o: [
                Vec4::splat(origin.x),
                Vec4::splat(origin.y),
                Vec4::splat(origin.z),
            ],
            d: [Vec4::splat(dir.x), Vec4::splat(dir.y), Vec4::splat(dir.z)],
            inv: [Vec4::splat(inv.x), Vec4::splat(inv.y), Vec4::splat(inv.z)],
            near: [near(inv.x, 0), near(inv.y, 1), near(inv.z, 2)],
            t_min,
            t_max,
        }
    }
}

/// Widening of each box's exit distance: the slab test rounds, and a ray
/// through a triangle lying on a box face must still enter the box
/// (robust BVH traversal, Ize 2013, uses 1 + 2 gamma(3); this is larger).
const EXIT_SCALE: f32 = 1.0 + 16.0 * f32::EPSILON;

/// The decoded tree.
pub(super) struct Bvh8 {
    /// Node 0 is the root (as in obvhs, whose node indices these are).
    nodes: Vec<Node>,
    packets: Vec<Packet>,
    /// Levels of inner nodes (0 for an empty tree).
    depth: usize,
}

/// A closest hit: distance, mesh face, barycentrics (u, v) in obvhs's
/// convention.
pub(super) struct Bvh8Hit {
    pub t: f32,
    pub face: u32,
    pub u: f32,
    pub v: f32,
}

/// Stack size of the fast path, on the call stack: trees up to 9 levels
/// never need more (each level leaves at most 7 children pending); deeper
/// ones get a heap stack of their size.
const SMALL_STACK: usize = 64;

impl Bvh8 {
    /// Decodes `bvh`, built over the mesh faces `tris`.
    pub(super) fn new(bvh: &CwBvh, tris: &[Triangle]) -> Self {
        let mut out = Bvh8 {
            nodes: Vec::new(),
            packets: Vec::new(),
            depth: 0,
        };
        if bvh.nodes.is_empty() || tris.is_empty() {
            return out;
        }
        out.nodes.resize(
            bvh.nodes.len(),
            Node {
                planes: [[Vec4::ZERO; 2]; 6],
                child: [0; 8],
                packet_base: 0,
                leaf_slots: 0,
            },
        );
        let (_, _, depth) = out.decode(bvh, tris, 0);
        out.depth = depth;
        out
    }

    /// Decodes obvhs node `index` into node `index` and its subtree;
    /// returns the exact bounds of its triangles and its depth.
    fn decode(&mut self, bvh: &CwBvh, tris: &[Triangle], index: usize) -> (Vec3A, Vec3A, usize) {
        let src = bvh.nodes[index];
        // Empty slots keep an infinite, inverted box: never entered.
        let mut planes = [[[f32::INFINITY; 4]; 2]; 6];
        for axis in 0..3 {
            planes[2 * axis + 1] = [[f32::NEG_INFINITY; 4]; 2];
        }
        let mut child = [0u32; 8];
        let mut leaf_slots = 0;
        let packet_base = self.packets.len();
        let mut lanes = 0;
        let mut depth = 1;
        let (mut lo_all, mut hi_all) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
        let mut set_box = |slot: usize, lo: Vec3A, hi: Vec3A| {
            let (h, l) = (slot / 4, slot % 4);
            for axis in 0..3 {
                planes[2 * axis][h][l] = lo[axis];
                planes[2 * axis + 1][h][l] = hi[axis];
            }
            lo_all = lo_all.min(lo);
            hi_all = hi_all.max(hi);
        };
        // The node's leaf triangles first, densely in packets of four (the
        // subtrees below append theirs after).
        for slot in (0..8).filter(|&s| !src.is_child_empty(s) && src.is_leaf(s)) {
            let (start, count) = src.child_primitives(slot);
            let (mut lo, mut hi) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
            for k in 0..count {
                let face = bvh.primitive_indices[(start + k) as usize];
                let t = &tris[face as usize];
                for v in [t.v0, t.v1, t.v2] {
                    lo = lo.min(v);
                    hi = hi.max(v);
                }
                if lanes % 4 == 0 {
                    self.packets.push(Packet::default());
                }
                let packet = self.packets.last_mut().expect("pushed above");
                packet.set_lane(lanes % 4, t, face);
                child[slot] |= 1 << lanes;
                lanes += 1;
            }
            leaf_slots |= 1 << slot;
            set_box(slot, lo, hi);
        }
        for slot in (0..8).filter(|&s| !src.is_child_empty(s) && !src.is_leaf(s)) {
            let c = src.child_node_index(slot) as usize;
            child[slot] = c as u32;
            let (lo, hi, d) = self.decode(bvh, tris, c);
            depth = depth.max(d + 1);
            set_box(slot, lo, hi);
        }
        self.nodes[index] = Node {
            planes: planes.map(|p| p.map(Vec4::from_array)),
            child,
            packet_base: packet_base as u32,
            leaf_slots,
        };
        (lo_all, hi_all, depth)
    }

    /// Bit mask of the children of `node` whose box the ray enters within
    /// `t_max`, with their entry distances.
    #[inline]
    fn enter(node: &Node, ray: &Bvh8Ray, t_max: f32) -> (u32, [Vec4; 2]) {
        let [nx, ny, nz] = ray.near;
        let mut mask = 0;
        let mut t_near = [Vec4::ZERO; 2];
        let t_lo = Vec4::splat(ray.t_min);
        let t_hi = Vec4::splat(t_max);
        for (h, near) in t_near.iter_mut().enumerate() {
            let slab =
                |plane: usize, axis: usize| (node.planes[plane][h] - ray.o[axis]) * ray.inv[axis];
            let t0 = slab(nx, 0).max(slab(ny, 1)).max(slab(nz, 2).max(t_lo));
            let t1 = slab(nx ^ 1, 0).min(slab(ny ^ 1, 1)).min(slab(nz ^ 1, 2)) * EXIT_SCALE;
            mask |= t0.cmple(t1.min(t_hi)).bitmask() << (4 * h);
            *near = t0;
        }
        (mask, t_near)
    }

    /// Distances at which the ray hits the packet's triangles within
    /// `[t_min, t_max]`, and the mask of lanes that hit.
    #[inline]
    fn hit_packet(p: &Packet, ray: &Bvh8Ray, t_max: f32) -> (Vec4, u32) {
        let dot = |a: &[Vec4; 3], b: &[Vec4; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let cross = |a: &[Vec4; 3], b: &[Vec4; 3]| {
            [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ]
        };
        let c = [p.v0[0] - ray.o[0], p.v0[1] - ray.o[1], p.v0[2] - ray.o[2]];
        let ng = cross(&p.e1, &p.e2);
        let r = cross(&ray.d, &c);
        let inv_det = Vec4::ONE / dot(&ng, &ray.d);
        let u = dot(&r, &p.e2) * inv_det;
        let v = dot(&r, &p.e1) * inv_det;
        let w = Vec4::ONE - u - v;
        let t = dot(&ng, &c) * inv_det;
        // NaN and infinite lanes (degenerate triangles, padding) fail one of
        // these comparisons.
        let hit = u.cmpge(Vec4::ZERO)
            & v.cmpge(Vec4::ZERO)
            & w.cmpge(Vec4::ZERO)
            & t.cmpge(Vec4::splat(ray.t_min))
            & t.cmple(Vec4::splat(t_max));
        (t, hit.bitmask())
    }

    /// Lanes of the leaf children in `leaf_hits` (a slot mask) of `node`.
    #[inline]
    fn leaf_lanes(node: &Node, mut leaf_hits: u32) -> u32 {
        let mut lanes = 0;
        while leaf_hits != 0 {
            lanes |= node.child[leaf_hits.trailing_zeros() as usize];
            leaf_hits &= leaf_hits - 1;
        }
        lanes
    }

    /// Memory taken by the nodes and packets.
    pub(super) fn bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<Node>()
            + self.packets.len() * std::mem::size_of::<Packet>()
    }

    /// Pending-node stack length that a traversal of this tree can fill.
    fn stack_len(&self) -> usize {
        7 * self.depth + 1
    }

    /// Whether any triangle lies on the ray within `[t_min, t_max)`.
    pub(super) fn any_hit(&self, ray: &Bvh8Ray) -> bool {
        if self.stack_len() <= SMALL_STACK {
            self.any_hit_in(ray, &mut [0; SMALL_STACK])
        } else {
            self.any_hit_in(ray, &mut vec![0; self.stack_len()])
        }
    }

    /// [`Bvh8::any_hit`] with a stack of at least [`Bvh8::stack_len`].
    fn any_hit_in(&self, ray: &Bvh8Ray, stack: &mut [u32]) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let mut top = 0;
        let mut cur = 0;
        // Strictly below t_max, as a closest hit.
        let t_max = ray.t_max.next_down();
        loop {
            let node = &self.nodes[cur];
            let (mask, _) = Self::enter(node, ray, t_max);
            let mut lanes = Self::leaf_lanes(node, mask & node.leaf_slots);
            let mut packet = node.packet_base as usize;
            while lanes != 0 {
                if lanes & 0xf != 0
                    && Self::hit_packet(&self.packets[packet], ray, t_max).1 & lanes != 0
                {
                    return true;
                }
                lanes >>= 4;
                packet += 1;
            }
            let mut inner = mask & !node.leaf_slots;
            while inner != 0 {
                stack[top] = node.child[inner.trailing_zeros() as usize];
                top += 1;
                inner &= inner - 1;
            }
            if top == 0 {
                return false;
            }
            top -= 1;
            cur = stack[top] as usize;
        }
    }
}

impl Packet {
    fn set_lane(&mut self, lane: usize, t: &Triangle, face: u32) {
        let e1 = t.v0 - t.v1;
        let e2 = t.v2 - t.v0;
        for axis in 0..3 {
            self.v0[axis][lane] = t.v0[axis];
            self.e1[axis][lane] = e1[axis];
            self.e2[axis][lane] = e2[axis];
        }
        self.face[lane] = face;
    }
}

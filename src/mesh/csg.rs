//! Constructive solid geometry on planar polygons with BSP trees (after
//! Evan Wallace's csg.js): union, difference and intersection of closed
//! polyhedra. Every polygon keeps the exact plane and the tag of the
//! primitive face it came from, so split pieces stay exactly on their plane
//! and the mesh can say which cut made each face.

use nalgebra::Vector3;

/// Classification tolerance, mm.
const EPS: f64 = 1e-7;

/// An oriented plane `n . x = w`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HalfSpace {
    /// Unit normal (outward for a solid's face).
    pub n: Vector3<f64>,
    /// Offset.
    pub w: f64,
}

impl HalfSpace {
    fn flip(&mut self) {
        self.n = -self.n;
        self.w = -self.w;
    }
}

/// A convex planar polygon with its plane and a tag.
#[derive(Clone, Debug, PartialEq)]
pub struct Polygon {
    /// Vertices, counter-clockwise seen from the front (outside).
    pub vertices: Vec<Vector3<f64>>,
    /// Its plane.
    pub plane: HalfSpace,
    /// Which primitive face it came from.
    pub tag: u32,
}

impl Polygon {
    fn flip(&mut self) {
        self.vertices.reverse();
        self.plane.flip();
    }

    /// Area, mm^2.
    pub fn area(&self) -> f64 {
        let v = &self.vertices;
        let mut a = Vector3::zeros();
        for i in 1..v.len().saturating_sub(1) {
            a += (v[i] - v[0]).cross(&(v[i + 1] - v[0]));
        }
        0.5 * a.norm()
    }
}

const COPLANAR: u8 = 0;
const FRONT: u8 = 1;
const BACK: u8 = 2;
const SPANNING: u8 = 3;

fn split(
    plane: &HalfSpace,
    poly: &Polygon,
    co_front: &mut Vec<Polygon>,
    co_back: &mut Vec<Polygon>,
    front: &mut Vec<Polygon>,
    back: &mut Vec<Polygon>,
) {
    let mut kind = 0u8;
    let types: Vec<u8> = poly
        .vertices
        .iter()
        .map(|v| {
            let t = plane.n.dot(v) - plane.w;
            let ty = if t < -EPS {
                BACK
            } else if t > EPS {
                FRONT
            } else {
                COPLANAR
            };
            kind |= ty;
            ty
        })
        .collect();
    match kind {
        COPLANAR => {
            if plane.n.dot(&poly.plane.n) > 0.0 {
                co_front.push(poly.clone());
            } else {
                co_back.push(poly.clone());
            }
        }
        FRONT => front.push(poly.clone()),
        BACK => back.push(poly.clone()),
        _ => {
            let (mut f, mut b) = (Vec::new(), Vec::new());
            let n = poly.vertices.len();
            for i in 0..n {
                let j = (i + 1) % n;
                let (ti, tj) = (types[i], types[j]);
                let (vi, vj) = (poly.vertices[i], poly.vertices[j]);
                if ti != BACK {
                    f.push(vi);
                }
                if ti != FRONT {
                    b.push(vi);
                }
                if (ti | tj) == SPANNING {
                    let t = (plane.w - plane.n.dot(&vi)) / plane.n.dot(&(vj - vi));
                    let v = vi + (vj - vi) * t;
                    f.push(v);
                    b.push(v);
                }
            }
            if f.len() >= 3 {
                front.push(Polygon {
                    vertices: f,
                    plane: poly.plane,
                    tag: poly.tag,
                });
            }
            if b.len() >= 3 {
                back.push(Polygon {
                    vertices: b,
                    plane: poly.plane,
                    tag: poly.tag,
                });
            }
        }
    }
}

#[derive(Default)]
struct Node {
    plane: Option<HalfSpace>,
    front: Option<Box<Node>>,
    back: Option<Box<Node>>,
    polygons: Vec<Polygon>,
}

impl Node {
    fn new(polygons: Vec<Polygon>) -> Node {
        let mut n = Node::default();
        n.build(polygons);
        n
    }

    fn invert(&mut self) {
        for p in &mut self.polygons {
            p.flip();
        }
        if let Some(p) = &mut self.plane {
            p.flip();
        }
        if let Some(f) = &mut self.front {
            f.invert();
        }
        if let Some(b) = &mut self.back {
            b.invert();
        }
        std::mem::swap(&mut self.front, &mut self.back);
    }

    fn clip_polygons(&self, polygons: Vec<Polygon>) -> Vec<Polygon> {
        let Some(plane) = &self.plane else {
            return polygons;
        };
        let (mut front, mut back) = (Vec::new(), Vec::new());
        for p in &polygons {
            let (mut cf, mut cb) = (Vec::new(), Vec::new());
            split(plane, p, &mut cf, &mut cb, &mut front, &mut back);
            front.append(&mut cf);
            back.append(&mut cb);
        }
        let mut front = match &self.front {
            Some(f) => f.clip_polygons(front),
            None => front,
        };
        let back = match &self.back {
            Some(b) => b.clip_polygons(back),
            None => Vec::new(),
        };
        front.extend(back);
        front
    }

    fn clip_to(&mut self, other: &Node) {
        self.polygons = other.clip_polygons(std::mem::take(&mut self.polygons));
        if let Some(f) = &mut self.front {
            f.clip_to(other);
        }
        if let Some(b) = &mut self.back {
            b.clip_to(other);
        }
    }

    fn all_polygons(&self) -> Vec<Polygon> {
        let mut v = self.polygons.clone();
        if let Some(f) = &self.front {
            v.extend(f.all_polygons());
        }
        if let Some(b) = &self.back {
            v.extend(b.all_polygons());
        }
        v
    }

    fn build(&mut self, polygons: Vec<Polygon>) {
        if polygons.is_empty() {
            return;
        }
        let plane = *self.plane.get_or_insert(polygons[0].plane);
        let (mut front, mut back) = (Vec::new(), Vec::new());
        for p in &polygons {
            let (mut cf, mut cb) = (Vec::new(), Vec::new());
            split(&plane, p, &mut cf, &mut cb, &mut front, &mut back);
            self.polygons.append(&mut cf);
            self.polygons.append(&mut cb);
        }
        if !front.is_empty() {
            self.front.get_or_insert_with(Box::default).build(front);
        }
        if !back.is_empty() {
            self.back.get_or_insert_with(Box::default).build(back);
        }
    }
}

/// A closed polyhedron as a set of polygons.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Csg {
    /// Its faces.
    pub polygons: Vec<Polygon>,
}

impl Csg {
    /// `self` minus `other`.
    pub(crate) fn subtract(&self, other: &Csg) -> Csg {
        let mut a = Node::new(self.polygons.clone());
        let mut b = Node::new(other.polygons.clone());
        a.invert();
        a.clip_to(&b);
        b.clip_to(&a);
        b.invert();
        b.clip_to(&a);
        b.invert();
        a.build(b.all_polygons());
        a.invert();
        Csg {
            polygons: a.all_polygons(),
        }
    }

    /// `self` or `other`.
    pub(crate) fn union(&self, other: &Csg) -> Csg {
        let mut a = Node::new(self.polygons.clone());
        let mut b = Node::new(other.polygons.clone());
        a.clip_to(&b);
        b.clip_to(&a);
        b.invert();
        b.clip_to(&a);
        b.invert();
        a.build(b.all_polygons());
        Csg {
            polygons: a.all_polygons(),
        }
    }

    /// Enclosed volume (divergence theorem), mm^3.
    pub fn volume(&self) -> f64 {
        let mut v = 0.0;
        for p in &self.polygons {
            let q = &p.vertices;
            for i in 1..q.len() - 1 {
                v += q[0].dot(&q[i].cross(&q[i + 1]));
            }
        }
        v / 6.0
    }
}

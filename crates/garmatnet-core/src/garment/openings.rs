//! The garment's openings: the boundary loops of its mesh (neck, hem, cuffs), found and
//! classified by where they are.

use std::collections::HashMap;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::math::{Real, Vec3};
use crate::mesh::TriMesh;

/// An opening of the garment (a boundary loop of its mesh).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Opening {
    /// The neck hole.
    Neck,
    /// The bottom hem.
    Hem,
    /// The left sleeve's cuff (+x, the body's left).
    LeftCuff,
    /// The right sleeve's cuff (-x).
    RightCuff,
}

/// A boundary loop: the vertices around one opening, in order.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BoundaryLoop {
    /// Which opening.
    pub opening: Opening,
    /// Vertex indices around the loop (first not repeated at the end).
    pub vertices: Vec<u32>,
}

/// The mesh's boundary loops, classified by where they are.
pub(crate) fn boundary_loops(mesh: &TriMesh) -> Result<Vec<BoundaryLoop>> {
    let mut count: HashMap<(u32, u32), usize> = HashMap::new();
    for f in &mesh.faces {
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            *count.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    // Directed boundary edges in face order, so each loop is walked consistently.
    let mut next: HashMap<u32, u32> = HashMap::new();
    for f in &mesh.faces {
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            if count[&(a.min(b), a.max(b))] == 1 && next.insert(a, b).is_some() {
                return Err(Error::InvalidMesh(format!(
                    "boundary vertex {a} is not manifold"
                )));
            }
        }
    }
    let mut starts: Vec<u32> = next.keys().copied().collect();
    starts.sort_unstable();
    let mut visited = std::collections::HashSet::new();
    let mut loops = Vec::new();
    for start in starts {
        if visited.contains(&start) {
            continue;
        }
        let mut ring = vec![start];
        visited.insert(start);
        let mut at = next[&start];
        while at != start {
            if !visited.insert(at) {
                return Err(Error::InvalidMesh("a boundary loop does not close".into()));
            }
            ring.push(at);
            at = *next
                .get(&at)
                .ok_or_else(|| Error::InvalidMesh("open boundary".into()))?;
        }
        loops.push(ring);
    }
    if loops.len() != 4 {
        return Err(Error::InvalidMesh(format!(
            "a T-shirt has 4 openings, the mesh has {} boundary loops",
            loops.len()
        )));
    }
    let centroid = |ring: &[u32]| {
        ring.iter()
            .map(|&i| mesh.vertices[i as usize])
            .sum::<Vec3>()
            / ring.len() as Real
    };
    let centres: Vec<Vec3> = loops.iter().map(|r| centroid(r)).collect();
    let by = |key: &dyn Fn(&Vec3) -> Real| {
        (0..4)
            .max_by(|&a, &b| key(&centres[a]).total_cmp(&key(&centres[b])))
            .unwrap_or(0)
    };
    let left = by(&|c| c.x);
    let right = by(&|c| -c.x);
    let hem = by(&|c| -c.y);
    let mut out = Vec::with_capacity(4);
    for (k, ring) in loops.into_iter().enumerate() {
        let opening = match k {
            _ if k == left => Opening::LeftCuff,
            _ if k == right => Opening::RightCuff,
            _ if k == hem => Opening::Hem,
            _ => Opening::Neck,
        };
        out.push(BoundaryLoop {
            opening,
            vertices: ring,
        });
    }
    Ok(out)
}

//! One MPI rank's share of a material approximation computed on the whole grid: the tetrahedra,
//! interface polygons and cut polygons a piece owns ([`PositionOwner`]: centroid in its half-open
//! cell box), with the points they use and, as global ids, each point's index in the whole output.
//! Every rank computes the same whole mesh bit for bit, so the shares partition it: their union is
//! the serial output, each cell on one rank, and points with the same global id are the same point
//! everywhere (the interfaces stay crack-free across the pieces' seams because they are the serial
//! interfaces).

use super::{MaterialMesh, PolygonMesh};
use crate::hierarchy::piece::{pick, used_points, PositionOwner};

impl MaterialMesh {
    /// The tetrahedra the piece of `owner` owns with every per-point and per-tetrahedron array, and
    /// each point's index in this mesh. The maxima and counts of the whole mesh
    /// (`max_interface_error`, `max_field_error`, `interface_tetrahedra`) are kept: they describe
    /// the approximation, of which this is a share.
    pub fn piece(&self, owner: &PositionOwner) -> (MaterialMesh, Vec<u64>) {
        let kept: Vec<u64> = (0..self.tets.len() as u64)
            .filter(|&t| {
                owner.owns(
                    self.tets[t as usize]
                        .iter()
                        .map(|&v| self.points[v as usize]),
                )
            })
            .collect();
        let (ids, local) = used_points(
            self.points.len(),
            kept.iter().map(|&t| self.tets[t as usize].as_slice()),
        );
        let columns = |c: &[Vec<f32>]| c.iter().map(|v| pick(v, &ids)).collect();
        let mesh = MaterialMesh {
            materials: self.materials,
            fields: self.fields,
            points: pick(&self.points, &ids),
            tets: kept
                .iter()
                .map(|&t| self.tets[t as usize].map(|v| local[v as usize]))
                .collect(),
            depths: pick(&self.depths, &kept),
            point_material: pick(&self.point_material, &ids),
            pairs: self.pairs.clone(),
            interface_distance: columns(&self.interface_distance),
            material_distance: columns(&self.material_distance),
            mixed: columns(&self.mixed),
            material_field: columns(&self.material_field),
            interface_error: pick(&self.interface_error, &kept),
            field_error: pick(&self.field_error, &kept),
            tet_materials: pick(&self.tet_materials, &kept),
            max_interface_error: self.max_interface_error,
            max_field_error: self.max_field_error,
            interface_tetrahedra: self.interface_tetrahedra,
            ghost_values: self.ghost_values,
        };
        (mesh, ids)
    }
}

impl PolygonMesh {
    /// The polygons the piece of `owner` owns with their labels and point values, and each point's
    /// index in this mesh.
    pub fn piece(&self, owner: &PositionOwner) -> (PolygonMesh, Vec<u64>) {
        let polygon =
            |i: usize| &self.connectivity[self.offsets[i] as usize..self.offsets[i + 1] as usize];
        let kept: Vec<u64> = (0..self.labels.len() as u64)
            .filter(|&i| owner.owns(polygon(i as usize).iter().map(|&v| self.points[v as usize])))
            .collect();
        let (ids, local) =
            used_points(self.points.len(), kept.iter().map(|&i| polygon(i as usize)));
        let mut offsets = vec![0u32];
        let mut connectivity = Vec::new();
        for &i in &kept {
            connectivity.extend(polygon(i as usize).iter().map(|&v| local[v as usize]));
            offsets.push(connectivity.len() as u32);
        }
        let polygons = PolygonMesh {
            points: pick(&self.points, &ids),
            offsets,
            connectivity,
            labels: pick(&self.labels, &kept),
            values: self.values.iter().map(|v| pick(v, &ids)).collect(),
        };
        (polygons, ids)
    }
}

//! Triangle meshes in body frame B (m): the renderer's one input shape, built from the analytic
//! model or read from Wavefront OBJ (`tobj`) or STL (`stl_io`) files.

use super::math::Vec3;
use anyhow::{Context, bail, ensure};
use std::path::Path;

/// An indexed triangle mesh. Winding need not be consistent: the renderer shades whichever side
/// faces the camera.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Mesh {
    /// Vertex positions in B, m.
    pub vertices: Vec<Vec3>,
    /// Triangles as indices into `vertices`.
    pub triangles: Vec<[u32; 3]>,
}

impl Mesh {
    /// Appends a vertex and returns its index.
    pub fn push_vertex(&mut self, v: Vec3) -> u32 {
        self.vertices.push(v);
        u32::try_from(self.vertices.len() - 1).expect("mesh vertex count fits in u32")
    }

    /// Appends a quad a-b-c-d as two triangles.
    pub fn push_quad(&mut self, a: u32, b: u32, c: u32, d: u32) {
        self.triangles.push([a, b, c]);
        self.triangles.push([a, c, d]);
    }

    /// Reads a mesh file by extension (`.obj` or `.stl`, any case), scaling its coordinates by
    /// `scale` (m per file unit).
    pub fn load(path: &Path, scale: f64) -> anyhow::Result<Mesh> {
        let extension = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        let mesh = match extension.as_deref() {
            Some("obj") => load_obj(path),
            Some("stl") => load_stl(path),
            _ => bail!("{}: a mesh must be a .obj or .stl file", path.display()),
        }
        .with_context(|| format!("reading mesh {}", path.display()))?;
        mesh.check()
            .with_context(|| format!("mesh {}", path.display()))?;
        Ok(Mesh {
            vertices: mesh.vertices.iter().map(|&v| v * scale).collect(),
            triangles: mesh.triangles,
        })
    }

    /// Checks that the mesh has triangles, finite vertices and valid indices.
    pub fn check(&self) -> anyhow::Result<()> {
        ensure!(!self.triangles.is_empty(), "no triangles");
        ensure!(
            self.vertices
                .iter()
                .all(|v| v.x.is_finite() && v.y.is_finite() && v.z.is_finite()),
            "a vertex is not finite"
        );
        let n = self.vertices.len();
        ensure!(
            self.triangles.iter().flatten().all(|&i| (i as usize) < n),
            "a triangle refers to a missing vertex"
        );
        Ok(())
    }

    /// The mesh as Wavefront OBJ text (the tests write the built-in shapes' meshes with it).
    pub fn to_obj(&self) -> String {
        use std::fmt::Write;
        let mut text = String::new();
        for v in &self.vertices {
            writeln!(text, "v {:e} {:e} {:e}", v.x, v.y, v.z).expect("writing to a String");
        }
        for [a, b, c] in &self.triangles {
            writeln!(text, "f {} {} {}", a + 1, b + 1, c + 1).expect("writing to a String");
        }
        text
    }
}

fn load_obj(path: &Path) -> anyhow::Result<Mesh> {
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, _materials) = tobj::load_obj(path, &options)?;
    let mut mesh = Mesh::default();
    for model in &models {
        let base = u32::try_from(mesh.vertices.len())?;
        mesh.vertices.extend(
            model
                .mesh
                .positions
                .chunks_exact(3)
                .map(|p| Vec3::new(p[0], p[1], p[2])),
        );
        for t in model.mesh.indices.chunks_exact(3) {
            mesh.triangles.push([base + t[0], base + t[1], base + t[2]]);
        }
    }
    Ok(mesh)
}

fn load_stl(path: &Path) -> anyhow::Result<Mesh> {
    let mut file = std::fs::File::open(path)?;
    let stl = stl_io::read_stl(&mut file)?;
    let vertices = stl
        .vertices
        .iter()
        .map(|v| Vec3::new(f64::from(v[0]), f64::from(v[1]), f64::from(v[2])))
        .collect();
    let triangles = stl
        .faces
        .iter()
        .map(|f| -> anyhow::Result<[u32; 3]> {
            Ok([
                u32::try_from(f.vertices[0])?,
                u32::try_from(f.vertices[1])?,
                u32::try_from(f.vertices[2])?,
            ])
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    Ok(Mesh {
        vertices,
        triangles,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tetrahedron() -> Mesh {
        let mut m = Mesh::default();
        for v in [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ] {
            m.push_vertex(Vec3::from_array(v));
        }
        m.triangles = vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
        m
    }

    #[test]
    fn obj_and_stl_files_load_and_scale() {
        let dir = tempfile::tempdir().unwrap();
        let tet = tetrahedron();
        let obj = dir.path().join("tet.OBJ");
        std::fs::write(&obj, tet.to_obj()).unwrap();
        let loaded = Mesh::load(&obj, 0.5).unwrap();
        let corners = |m: &Mesh, scale: f64| -> Vec<[Vec3; 3]> {
            m.triangles
                .iter()
                .map(|t| t.map(|i| m.vertices[i as usize] * scale))
                .collect()
        };
        assert_eq!(corners(&loaded, 1.0), corners(&tet, 0.5));

        let stl = dir.path().join("tet.stl");
        let triangles: Vec<stl_io::Triangle> = tet
            .triangles
            .iter()
            .map(|t| {
                let corner = |i: u32| {
                    let v = tet.vertices[i as usize];
                    stl_io::Vertex::new([v.x as f32, v.y as f32, v.z as f32])
                };
                stl_io::Triangle {
                    normal: stl_io::Normal::new([0.0, 0.0, 0.0]),
                    vertices: [corner(t[0]), corner(t[1]), corner(t[2])],
                }
            })
            .collect();
        let mut file = std::fs::File::create(&stl).unwrap();
        stl_io::write_stl(&mut file, triangles.iter()).unwrap();
        drop(file);
        let loaded = Mesh::load(&stl, 2.0).unwrap();
        assert_eq!(loaded.triangles.len(), 4);
        assert!(loaded.vertices.contains(&Vec3::new(0.0, 0.0, 2.0)));

        assert!(Mesh::load(&dir.path().join("tet.ply"), 1.0).is_err());
        std::fs::write(dir.path().join("empty.obj"), "# nothing\n").unwrap();
        assert!(Mesh::load(&dir.path().join("empty.obj"), 1.0).is_err());
    }
}

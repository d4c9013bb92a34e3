//! Small f64 linear algebra for the simulator, with every transcendental function taken from the
//! pure-Rust `libm` crate so that results do not depend on the machine's C library.
//!
//! The simulator keeps its own vector and rotation types on purpose: it must not share geometry
//! code with `imade-core`, whose results it is used to judge.

use std::ops::{Add, Mul, Neg, Sub};

/// Degrees to radians.
pub fn rad(deg: f64) -> f64 {
    deg * (std::f64::consts::PI / 180.0)
}

/// Radians to degrees.
pub fn deg(rad: f64) -> f64 {
    rad * (180.0 / std::f64::consts::PI)
}

/// Wraps an angle in degrees to (-180, 180].
pub fn wrap_deg(a: f64) -> f64 {
    let w = a - 360.0 * libm::floor((a + 180.0) / 360.0);
    if w <= -180.0 { w + 360.0 } else { w }
}

/// Hermite smoothstep of `x` between `edge0` and `edge1`: 0 below, 1 above, C1 in between.
pub fn smoothstep(edge0: f64, edge1: f64, x: f64) -> f64 {
    let t = ((x - edge0) / (edge1 - edge0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Linear interpolation from `a` (t = 0) to `b` (t = 1).
pub fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a + (b - a) * t
}

/// A 3-vector (a point or a direction; the frame is named where it is used).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Vec3 {
    /// First component.
    pub x: f64,
    /// Second component.
    pub y: f64,
    /// Third component.
    pub z: f64,
}

impl Vec3 {
    /// The vector (x, y, z).
    pub const fn new(x: f64, y: f64, z: f64) -> Vec3 {
        Vec3 { x, y, z }
    }

    /// The vector from an array.
    pub const fn from_array(a: [f64; 3]) -> Vec3 {
        Vec3::new(a[0], a[1], a[2])
    }

    /// Dot product.
    pub fn dot(self, o: Vec3) -> f64 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    /// Cross product `self x o`.
    pub fn cross(self, o: Vec3) -> Vec3 {
        Vec3::new(
            self.y * o.z - self.z * o.y,
            self.z * o.x - self.x * o.z,
            self.x * o.y - self.y * o.x,
        )
    }

    /// Euclidean length.
    pub fn norm(self) -> f64 {
        libm::sqrt(self.dot(self))
    }

    /// The unit vector along `self` (the zero vector stays zero).
    pub fn normalized(self) -> Vec3 {
        let n = self.norm();
        if n > 0.0 { self * (1.0 / n) } else { self }
    }
}

impl Add for Vec3 {
    type Output = Vec3;
    fn add(self, o: Vec3) -> Vec3 {
        Vec3::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}

impl Sub for Vec3 {
    type Output = Vec3;
    fn sub(self, o: Vec3) -> Vec3 {
        Vec3::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}

impl Mul<f64> for Vec3 {
    type Output = Vec3;
    fn mul(self, s: f64) -> Vec3 {
        Vec3::new(self.x * s, self.y * s, self.z * s)
    }
}

impl Neg for Vec3 {
    type Output = Vec3;
    fn neg(self) -> Vec3 {
        Vec3::new(-self.x, -self.y, -self.z)
    }
}

/// A 3x3 matrix, row-major: `m[row][col]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mat3 {
    /// The entries, `m[row][col]`.
    pub m: [[f64; 3]; 3],
}

impl Mat3 {
    /// The identity.
    pub const IDENTITY: Mat3 = Mat3 {
        m: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
    };

    /// The matrix whose columns are `a`, `b`, `c`.
    pub fn from_cols(a: Vec3, b: Vec3, c: Vec3) -> Mat3 {
        Mat3 {
            m: [[a.x, b.x, c.x], [a.y, b.y, c.y], [a.z, b.z, c.z]],
        }
    }

    /// Column `j`.
    pub fn col(&self, j: usize) -> Vec3 {
        Vec3::new(self.m[0][j], self.m[1][j], self.m[2][j])
    }

    /// Row `i`.
    pub fn row(&self, i: usize) -> Vec3 {
        Vec3::from_array(self.m[i])
    }

    /// The transpose (the inverse of a rotation).
    pub fn transpose(&self) -> Mat3 {
        Mat3::from_cols(self.row(0), self.row(1), self.row(2))
    }

    /// Right-handed rotation by `a` radians about +x: `[[1,0,0],[0,c,-s],[0,s,c]]`.
    pub fn rot_x(a: f64) -> Mat3 {
        let (s, c) = (libm::sin(a), libm::cos(a));
        Mat3 {
            m: [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]],
        }
    }

    /// Right-handed rotation by `a` radians about +y: `[[c,0,s],[0,1,0],[-s,0,c]]`.
    pub fn rot_y(a: f64) -> Mat3 {
        let (s, c) = (libm::sin(a), libm::cos(a));
        Mat3 {
            m: [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]],
        }
    }

    /// Right-handed rotation by `a` radians about +z: `[[c,-s,0],[s,c,0],[0,0,1]]`.
    pub fn rot_z(a: f64) -> Mat3 {
        let (s, c) = (libm::sin(a), libm::cos(a));
        Mat3 {
            m: [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]],
        }
    }

    /// The largest absolute entry of `self - o`.
    pub fn max_abs_diff(&self, o: &Mat3) -> f64 {
        let mut worst: f64 = 0.0;
        for i in 0..3 {
            for j in 0..3 {
                worst = worst.max((self.m[i][j] - o.m[i][j]).abs());
            }
        }
        worst
    }
}

impl Mul<Vec3> for Mat3 {
    type Output = Vec3;
    fn mul(self, v: Vec3) -> Vec3 {
        Vec3::new(self.row(0).dot(v), self.row(1).dot(v), self.row(2).dot(v))
    }
}

impl Mul for Mat3 {
    type Output = Mat3;
    fn mul(self, o: Mat3) -> Mat3 {
        Mat3::from_cols(self * o.col(0), self * o.col(1), self * o.col(2))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_deg_lands_in_half_open_interval() {
        assert_eq!(wrap_deg(180.0), 180.0);
        assert_eq!(wrap_deg(-180.0), 180.0);
        assert_eq!(wrap_deg(190.0), -170.0);
        assert_eq!(wrap_deg(-725.0), -5.0);
    }

    #[test]
    fn elementary_rotations_are_right_handed() {
        let v = Mat3::rot_z(rad(90.0)) * Vec3::new(1.0, 0.0, 0.0);
        assert!((v - Vec3::new(0.0, 1.0, 0.0)).norm() < 1e-15);
        let v = Mat3::rot_x(rad(90.0)) * Vec3::new(0.0, 0.0, 1.0);
        assert!((v - Vec3::new(0.0, -1.0, 0.0)).norm() < 1e-15);
        let v = Mat3::rot_y(rad(90.0)) * Vec3::new(0.0, 0.0, 1.0);
        assert!((v - Vec3::new(1.0, 0.0, 0.0)).norm() < 1e-15);
    }
}

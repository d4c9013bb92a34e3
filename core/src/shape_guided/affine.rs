//! 2D affine maps of chip coordinates (px; x right, y down, pixel centres at integers), and the
//! seven-parameter family that SIS-Cut searches.

use super::prior::PriorShape;
use nalgebra::{Matrix2, Vector2};

/// `p -> linear * p + offset`, in chip pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Affine2 {
    /// Row-major 2 x 2 linear part `[[a, b], [c, d]]`.
    pub linear: [[f32; 2]; 2],
    /// Translation, px.
    pub offset: [f32; 2],
}

impl Affine2 {
    /// The identity map.
    pub const IDENTITY: Affine2 = Affine2 {
        linear: [[1.0, 0.0], [0.0, 1.0]],
        offset: [0.0, 0.0],
    };

    /// The map `p -> centre + shift + linear (p - centre)`.
    pub fn about(centre: Vector2<f32>, linear: Matrix2<f32>, shift: Vector2<f32>) -> Affine2 {
        Affine2::from_parts(linear, centre + shift - linear * centre)
    }

    fn from_parts(linear: Matrix2<f32>, offset: Vector2<f32>) -> Affine2 {
        Affine2 {
            linear: [[linear.m11, linear.m12], [linear.m21, linear.m22]],
            offset: [offset.x, offset.y],
        }
    }

    /// The linear part as a matrix.
    pub fn matrix(&self) -> Matrix2<f32> {
        let [[a, b], [c, d]] = self.linear;
        Matrix2::new(a, b, c, d)
    }

    /// The translation as a vector, px.
    pub fn translation(&self) -> Vector2<f32> {
        Vector2::new(self.offset[0], self.offset[1])
    }

    /// The image of point `p`.
    #[inline]
    pub fn apply(&self, p: Vector2<f32>) -> Vector2<f32> {
        self.matrix() * p + self.translation()
    }

    /// `self` followed by `next`: `p -> next(self(p))`.
    pub fn then(&self, next: &Affine2) -> Affine2 {
        let a = next.matrix();
        Affine2::from_parts(
            a * self.matrix(),
            a * self.translation() + next.translation(),
        )
    }

    /// The inverse map, or `None` when the linear part is singular or not finite.
    pub fn inverse(&self) -> Option<Affine2> {
        let m = self.matrix();
        let det = m.determinant();
        if !(det.is_finite() && det.abs() > 1e-6) {
            return None;
        }
        let inv = Matrix2::new(m.m22, -m.m12, -m.m21, m.m11) / det;
        Some(Affine2::from_parts(inv, -(inv * self.translation())))
    }

    /// True when every coefficient is finite.
    pub fn is_finite(&self) -> bool {
        self.linear.iter().flatten().all(|v| v.is_finite())
            && self.offset.iter().all(|v| v.is_finite())
    }
}

/// The seven parameters of SIS-Cut's transform (the source paper's Algorithm 2), expressed in
/// the prior's principal-axis frame (u along the body axis, v across it) about the prior's
/// centroid: `p -> c + E (shift + R(rotation) Sh Sc E^T (p - c))`, with `E = [u v]`,
/// `Sh = [[1, shear_u], [shear_v, 1]]`, `Sc = diag(exp(log_scale_u), exp(log_scale_v))`.
/// Zero everywhere is the identity. The scales are logarithmic so that growing and shrinking
/// are symmetric for the simplex search.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AffineParams {
    /// Natural log of the scale along the body axis.
    pub log_scale_u: f32,
    /// Natural log of the scale across the body axis.
    pub log_scale_v: f32,
    /// Rotation, rad (positive from u towards v).
    pub rotation_rad: f32,
    /// Shear of u by v.
    pub shear_u: f32,
    /// Shear of v by u.
    pub shear_v: f32,
    /// Translation along the body axis, px.
    pub shift_u_px: f32,
    /// Translation across the body axis, px.
    pub shift_v_px: f32,
}

impl AffineParams {
    /// The parameters as a vector, in declaration order.
    pub fn to_array(&self) -> [f32; 7] {
        [
            self.log_scale_u,
            self.log_scale_v,
            self.rotation_rad,
            self.shear_u,
            self.shear_v,
            self.shift_u_px,
            self.shift_v_px,
        ]
    }

    /// The parameters from a vector in declaration order.
    pub fn from_array(p: &[f32; 7]) -> AffineParams {
        let [
            log_scale_u,
            log_scale_v,
            rotation_rad,
            shear_u,
            shear_v,
            shift_u_px,
            shift_v_px,
        ] = *p;
        AffineParams {
            log_scale_u,
            log_scale_v,
            rotation_rad,
            shear_u,
            shear_v,
            shift_u_px,
            shift_v_px,
        }
    }

    /// The chip-pixel map these parameters describe in the frame of `shape`.
    pub fn affine(&self, shape: &PriorShape) -> Affine2 {
        let (s, c) = libm::sincosf(self.rotation_rad);
        let rotation = Matrix2::new(c, -s, s, c);
        let shear = Matrix2::new(1.0, self.shear_u, self.shear_v, 1.0);
        let scale = Matrix2::new(
            libm::expf(self.log_scale_u),
            0.0,
            0.0,
            libm::expf(self.log_scale_v),
        );
        let e = shape.frame();
        let linear = e * rotation * shear * scale * e.transpose();
        let shift = e * Vector2::new(self.shift_u_px, self.shift_v_px);
        Affine2::about(shape.centre, linear, shift)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Vector2<f32>, b: Vector2<f32>) -> bool {
        (a - b).norm() < 1e-4
    }

    #[test]
    fn composition_and_inverse() {
        let rot = Matrix2::new(0.0, -2.0, 2.0, 0.0); // 90 deg, scale 2
        let a = Affine2::about(Vector2::new(10.0, 5.0), rot, Vector2::new(1.0, 0.0));
        // (11, 5) is 1 px right of the centre: turned to 2 px down, then shifted 1 px right.
        assert!(close(
            a.apply(Vector2::new(11.0, 5.0)),
            Vector2::new(11.0, 7.0)
        ));
        let inv = a.inverse().expect("invertible");
        let p = Vector2::new(-3.0, 8.5);
        assert!(close(inv.apply(a.apply(p)), p));
        assert!(close(a.then(&inv).apply(p), p));
        let b = Affine2::about(
            Vector2::zeros(),
            Matrix2::identity(),
            Vector2::new(0.0, 4.0),
        );
        assert!(close(a.then(&b).apply(p), b.apply(a.apply(p))));
    }

    #[test]
    fn singular_map_has_no_inverse() {
        let flat = Affine2::about(
            Vector2::zeros(),
            Matrix2::new(1.0, 2.0, 2.0, 4.0),
            Vector2::zeros(),
        );
        assert_eq!(flat.inverse(), None);
    }

    #[test]
    fn parameters_act_in_the_body_frame() {
        // A body along the image diagonal.
        let shape = PriorShape::for_tests(Vector2::new(50.0, 40.0), 0.25 * core::f32::consts::PI);
        let axis = shape.axis;
        let id = AffineParams::default().affine(&shape);
        assert!(close(
            id.apply(Vector2::new(3.0, 7.0)),
            Vector2::new(3.0, 7.0)
        ));
        // Scaling along u by 2 doubles the distance of an on-axis point from the centre and
        // leaves an across-axis point where it is.
        let p = AffineParams {
            log_scale_u: libm::logf(2.0),
            ..Default::default()
        }
        .affine(&shape);
        let across = Vector2::new(-axis.y, axis.x);
        assert!(close(
            p.apply(shape.centre + 5.0 * axis),
            shape.centre + 10.0 * axis
        ));
        assert!(close(
            p.apply(shape.centre + 3.0 * across),
            shape.centre + 3.0 * across
        ));
        // A shift along u moves everything along the axis.
        let t = AffineParams {
            shift_u_px: 4.0,
            ..Default::default()
        }
        .affine(&shape);
        assert!(close(t.apply(shape.centre), shape.centre + 4.0 * axis));
        let arr = [0.1, -0.2, 0.3, 0.01, -0.02, 1.5, -2.5];
        assert_eq!(AffineParams::from_array(&arr).to_array(), arr);
    }
}

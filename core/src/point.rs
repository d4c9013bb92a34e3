//! The image-plane point that stages hand each other: a position or a displacement, px (x right,
//! y down; chip or full-frame px as each field says). Plain `f32` arithmetic, never fused, so the
//! host and the firmware compute the same bits; converts to and from nalgebra's `Vector2` for
//! the linear algebra inside a stage.

use core::ops::{Add, Mul, Neg, Sub};
use nalgebra::Vector2;

/// A point, or a displacement or direction, in the image plane, px.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ImagePoint {
    /// Right, px.
    pub x: f32,
    /// Down, px.
    pub y: f32,
}

impl ImagePoint {
    /// The point `(x, y)`.
    pub const fn new(x: f32, y: f32) -> Self {
        ImagePoint { x, y }
    }

    /// The dot product with `other`.
    pub fn dot(self, other: ImagePoint) -> f32 {
        self.x * other.x + self.y * other.y
    }

    /// The length, px.
    pub fn norm(self) -> f32 {
        libm::sqrtf(self.dot(self))
    }

    /// The direction turned by +90 degrees in the image (x right, y down): `(-y, x)`.
    pub fn perpendicular(self) -> ImagePoint {
        ImagePoint::new(-self.y, self.x)
    }

    /// The centre of the integer pixel `(x, y)` (a chip's top-left in the full frame, say).
    pub fn of_pixel((x, y): (i32, i32)) -> ImagePoint {
        ImagePoint::new(x as f32, y as f32)
    }

    /// True when both coordinates are finite.
    pub fn is_finite(self) -> bool {
        self.x.is_finite() && self.y.is_finite()
    }
}

impl Add for ImagePoint {
    type Output = ImagePoint;
    fn add(self, other: ImagePoint) -> ImagePoint {
        ImagePoint::new(self.x + other.x, self.y + other.y)
    }
}

impl Sub for ImagePoint {
    type Output = ImagePoint;
    fn sub(self, other: ImagePoint) -> ImagePoint {
        ImagePoint::new(self.x - other.x, self.y - other.y)
    }
}

impl Mul<f32> for ImagePoint {
    type Output = ImagePoint;
    fn mul(self, factor: f32) -> ImagePoint {
        ImagePoint::new(self.x * factor, self.y * factor)
    }
}

impl Neg for ImagePoint {
    type Output = ImagePoint;
    fn neg(self) -> ImagePoint {
        ImagePoint::new(-self.x, -self.y)
    }
}

impl From<ImagePoint> for Vector2<f32> {
    fn from(p: ImagePoint) -> Vector2<f32> {
        Vector2::new(p.x, p.y)
    }
}

impl From<Vector2<f32>> for ImagePoint {
    fn from(v: Vector2<f32>) -> ImagePoint {
        ImagePoint::new(v.x, v.y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arithmetic_and_conversions() {
        let (a, b) = (ImagePoint::new(3.0, -4.0), ImagePoint::new(0.5, 2.0));
        assert_eq!(a + b, ImagePoint::new(3.5, -2.0));
        assert_eq!(a - b, ImagePoint::new(2.5, -6.0));
        assert_eq!(a * 2.0, ImagePoint::new(6.0, -8.0));
        assert_eq!(-a, ImagePoint::new(-3.0, 4.0));
        assert_eq!(a.dot(b), -6.5);
        assert_eq!(a.norm(), 5.0);
        assert_eq!(a.perpendicular(), ImagePoint::new(4.0, 3.0));
        assert_eq!(ImagePoint::from(Vector2::from(a)), a);
        assert!(!ImagePoint::new(f32::NAN, 0.0).is_finite());
    }
}

//! The general camera of the lecture notes ("General Camera"), in f64.
//!
//! View coordinates (u, v, n) are **left-handed**: u points to the image's right, v up, and n into
//! the scene. From the View Plane Normal (VPN) and View Up Vector (VUV), "Finding the basis
//! vectors":
//!
//! ```text
//! n = VPN / |VPN|      u = (n × VUV) / |n × VUV|      v = u × n
//! ```
//!
//! The view plane is n = 0 through the View Reference Point (VRP); the window is centred on the
//! VRP; the Centre Of Projection (COP) is a point in view coordinates, usually (0, 0, −d).

use glam::{DMat4, DVec2, DVec3, DVec4};

/// Below this sine of the angle between VPN and VUV (1e-9 rad) the two count as parallel and
/// `n × VUV` no longer defines u.
pub const PARALLEL_SINE: f64 = 1e-9;

/// Orthonormal view basis in world coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Basis {
    /// Image right.
    pub u: DVec3,
    /// Image up.
    pub v: DVec3,
    /// Into the scene (the normalised VPN).
    pub n: DVec3,
}

/// Why a camera could not be formed.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CameraError {
    /// VPN is zero, or not finite.
    #[error(
        "the view plane normal (VPN) is zero or not finite; with a target point, TP equals VRP"
    )]
    ZeroVpn,
    /// VUV is zero, or not finite.
    #[error("the view up vector (VUV) is zero or not finite")]
    ZeroVuv,
    /// VPN and VUV are parallel (within 1e-9 rad) and there is no previous frame to follow.
    #[error(
        "VPN is parallel to VUV, so no image 'up' is defined; change vuv or the view direction"
    )]
    Parallel,
    /// The COP's n is not < 0 (an overshooting zoom track can push it through the view plane).
    #[error("the COP's n is {0}, not < 0; a CatmullRom Zoom track may overshoot: use Monotone")]
    CopNotBehind(f64),
}

impl Basis {
    /// The notes' basis from a view plane normal and a view up vector (neither need be unit).
    pub fn from_vpn_vuv(vpn: DVec3, vuv: DVec3) -> Result<Basis, CameraError> {
        Basis::following(vpn, vuv, None)
    }

    /// The notes' basis, continued from the previous frame's `v` when there is one.
    ///
    /// The rule, for animation:
    /// - when VPN and VUV are parallel (within [`PARALLEL_SINE`]), v is the previous frame's v
    ///   made orthogonal to the new n (parallel transport), and u = n × v;
    /// - when the notes' basis would roll more than 90° from the previous frame's v (which happens
    ///   only as n passes through ±VUV), u and v are both negated: the camera carries on over
    ///   the pole instead of flipping 180° about n between two frames.
    ///
    /// Away from the pole this is exactly the notes' basis.
    pub fn following(
        vpn: DVec3,
        vuv: DVec3,
        previous_v: Option<DVec3>,
    ) -> Result<Basis, CameraError> {
        let len = vpn.length();
        if !(len.is_finite() && len > 0.0) {
            return Err(CameraError::ZeroVpn);
        }
        let vuv_len = vuv.length();
        if !(vuv_len.is_finite() && vuv_len > 0.0) {
            return Err(CameraError::ZeroVuv);
        }
        let n = vpn / len;
        let side = n.cross(vuv / vuv_len);
        let sine = side.length();
        if sine > PARALLEL_SINE {
            let u = side / sine;
            let v = u.cross(n);
            return Ok(match previous_v {
                Some(prev) if prev.dot(v) < 0.0 => Basis { u: -u, v: -v, n },
                _ => Basis { u, v, n },
            });
        }
        let prev = previous_v.ok_or(CameraError::Parallel)?;
        let v = (prev - n * prev.dot(n))
            .try_normalize()
            .ok_or(CameraError::Parallel)?;
        Ok(Basis {
            u: n.cross(v),
            v,
            n,
        })
    }

    /// The basis turned `degrees` about n, counterclockwise as seen from behind the camera
    /// (looking along n): v turns towards −u, and the scene in the picture turns clockwise.
    /// Blender's roll (its camera's turn about local Z), Cinemachine's Dutch. Zero degrees is
    /// the basis itself, bit for bit.
    pub fn rolled(self, degrees: f64) -> Basis {
        if degrees == 0.0 {
            return self;
        }
        let radians = degrees * (std::f64::consts::PI / 180.0);
        let (s, c) = (libm::sin(radians), libm::cos(radians));
        Basis {
            u: self.u * c + self.v * s,
            v: self.v * c - self.u * s,
            n: self.n,
        }
    }

    /// World direction to view coordinates (rotation only).
    pub fn to_view(&self, world: DVec3) -> DVec3 {
        DVec3::new(world.dot(self.u), world.dot(self.v), world.dot(self.n))
    }

    /// View direction to world coordinates (rotation only).
    pub fn to_world(&self, view: DVec3) -> DVec3 {
        self.u * view.x + self.v * view.y + self.n * view.z
    }
}

/// A camera at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// View Reference Point in world coordinates: origin of the view coordinates.
    pub vrp_world: DVec3,
    /// The UVN basis (u right, v up, n into the scene; left-handed view coordinates).
    pub basis: Basis,
    /// Centre Of Projection in view coordinates (u, v, n); n < 0.
    pub cop_view: DVec3,
    /// Window (width, height) on the view plane, centred on the VRP, in world units.
    pub window: DVec2,
}

impl Camera {
    /// Whether `other` is this camera bit for bit: what decides that a frame's pixels are
    /// another's (−0.0 and +0.0 differ here, as in the frame key, where `==` takes them alike).
    pub fn same_bits(&self, other: &Camera) -> bool {
        let b = self.basis;
        let o = other.basis;
        let mine = [self.vrp_world, b.u, b.v, b.n, self.cop_view];
        let theirs = [other.vrp_world, o.u, o.v, o.n, other.cop_view];
        let bits3 = |v: &DVec3| v.to_array().map(f64::to_bits);
        mine.iter().map(bits3).eq(theirs.iter().map(bits3))
            && self.window.to_array().map(f64::to_bits) == other.window.to_array().map(f64::to_bits)
    }

    /// Whether two lists of cameras are the same bit for bit ([`Camera::same_bits`]).
    pub fn all_same_bits(a: &[Camera], b: &[Camera]) -> bool {
        a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.same_bits(y))
    }

    /// The notes' world-to-view matrix M = [[R, 0], [−qR, 1]] with R = (uᵀ vᵀ nᵀ) and q = VRP.
    ///
    /// The notes multiply row vectors on the left (p·M); glam multiplies column vectors on the
    /// right (M'·p), so this returns M' = Mᵀ: `world_to_view().transform_point3(p)` gives (u, v, n),
    /// and the columns of M' (`to_cols_array_2d`) are the rows of the notes' M.
    pub fn world_to_view(&self) -> DMat4 {
        let Basis { u, v, n } = self.basis;
        let q = self.vrp_world;
        DMat4::from_cols(
            DVec4::new(u.x, v.x, n.x, 0.0),
            DVec4::new(u.y, v.y, n.y, 0.0),
            DVec4::new(u.z, v.z, n.z, 0.0),
            DVec4::new(-q.dot(u), -q.dot(v), -q.dot(n), 1.0),
        )
    }

    /// A world point in view coordinates. Subtracts the VRP first, so that a camera far from the
    /// origin keeps the precision of its neighbourhood (the matrix form loses it in −q·R).
    pub fn point_to_view(&self, world: DVec3) -> DVec3 {
        self.basis.to_view(world - self.vrp_world)
    }

    /// A view point in world coordinates.
    pub fn point_to_world(&self, view: DVec3) -> DVec3 {
        self.vrp_world + self.basis.to_world(view)
    }

    /// The COP in world coordinates.
    pub fn cop_world(&self) -> DVec3 {
        self.point_to_world(self.cop_view)
    }
}

/// The point on the view plane (view coordinates, n = 0) that position (`px`, `py`) of an image
/// `size` pixels wide and high maps to; (0, 0) is the top-left corner of the image and pixel (i, j)
/// has its centre at (i + ½, j + ½).
pub fn window_point(window: DVec2, size: (u32, u32), px: f64, py: f64) -> DVec3 {
    let x = px / size.0 as f64 * window.x - window.x * 0.5;
    let y = window.y * 0.5 - py / size.1 as f64 * window.y;
    DVec3::new(x, y, 0.0)
}

/// The window (width, height) that gives the field of view `fov_deg` (degrees, in (0, 180)) at
/// distance `d` from the COP to the view plane.
pub fn window_extent(fov_deg: f64, d: f64) -> f64 {
    2.0 * d * libm::tan(fov_deg.to_radians() * 0.5)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn camera(vrp: DVec3, vpn: DVec3, vuv: DVec3) -> Camera {
        Camera {
            vrp_world: vrp,
            basis: Basis::from_vpn_vuv(vpn, vuv).unwrap(),
            cop_view: DVec3::new(0.0, 0.0, -1.0),
            window: DVec2::new(1.0, 1.0),
        }
    }

    #[test]
    fn same_bits_tells_a_negative_zero_from_a_positive_one() {
        let a = camera(DVec3::ZERO, DVec3::Z, DVec3::Y);
        assert!(a.same_bits(&a.clone()));
        assert!(Camera::all_same_bits(&[a], &[a]));
        assert!(!Camera::all_same_bits(&[a], &[a, a]));
        let mut b = a;
        b.vrp_world.x = -0.0;
        assert_eq!(a, b, "== takes the two zeros alike");
        assert!(!a.same_bits(&b));
        let mut c = a;
        c.window.y = f64::from_bits(1.0f64.to_bits() + 1);
        assert!(!a.same_bits(&c));
    }

    /// The inverse of `world_to_view`, the notes' [[Rᵀ, 0], [q, 1]] (transposed for glam).
    fn view_to_world(cam: &Camera) -> DMat4 {
        let Basis { u, v, n } = cam.basis;
        DMat4::from_cols(
            u.extend(0.0),
            v.extend(0.0),
            n.extend(0.0),
            cam.vrp_world.extend(1.0),
        )
    }

    /// Row-vector product p·M with the notes' matrix written out by hand.
    fn row_times(p: [f64; 4], m: [[f64; 4]; 4]) -> [f64; 4] {
        let mut out = [0.0; 4];
        for (c, o) in out.iter_mut().enumerate() {
            *o = (0..4).map(|r| p[r] * m[r][c]).sum();
        }
        out
    }

    #[test]
    fn looking_down_world_z_gives_u_to_minus_x() {
        // n = (0,0,1), VUV = (0,1,0): n × VUV = (−1, 0, 0) by the cross product's definition.
        let b = Basis::from_vpn_vuv(DVec3::Z * 3.0, DVec3::Y).unwrap();
        assert_eq!(b.u, DVec3::new(-1.0, 0.0, 0.0));
        assert_eq!(b.v, DVec3::new(0.0, 1.0, 0.0));
        assert_eq!(b.n, DVec3::new(0.0, 0.0, 1.0));
    }

    #[test]
    fn notes_matrix_layout_and_inverse() {
        let cam = camera(
            DVec3::new(1.0, 2.0, 3.0),
            DVec3::new(0.3, -0.2, 1.0),
            DVec3::Y,
        );
        // glam's columns of M' = Mᵀ are the rows of the notes' M.
        let m = cam.world_to_view().to_cols_array_2d();
        let Basis { u, v, n } = cam.basis;
        let q = cam.vrp_world;
        let expect = [
            [u.x, v.x, n.x, 0.0],
            [u.y, v.y, n.y, 0.0],
            [u.z, v.z, n.z, 0.0],
            [
                -(q.x * u.x + q.y * u.y + q.z * u.z),
                -(q.x * v.x + q.y * v.y + q.z * v.z),
                -(q.x * n.x + q.y * n.y + q.z * n.z),
                1.0,
            ],
        ];
        assert_eq!(m, expect);
        // uR = i, vR = j, nR = k with R the top-left 3×3 of M.
        for (axis, e) in [
            (u, [1.0, 0.0, 0.0]),
            (v, [0.0, 1.0, 0.0]),
            (n, [0.0, 0.0, 1.0]),
        ] {
            let got = row_times([axis.x, axis.y, axis.z, 0.0], m);
            for k in 0..3 {
                assert!((got[k] - e[k]).abs() < 1e-15, "{got:?} vs {e:?}");
            }
        }
        // q·M = (0, 0, 0, 1).
        let origin = row_times([q.x, q.y, q.z, 1.0], m);
        for (k, want) in [0.0, 0.0, 0.0, 1.0].into_iter().enumerate() {
            assert!((origin[k] - want).abs() < 1e-14);
        }
        // M·M⁻¹ = I, with M⁻¹ = [[Rᵀ, 0], [q, 1]] written from the notes.
        let inv = [
            [u.x, u.y, u.z, 0.0],
            [v.x, v.y, v.z, 0.0],
            [n.x, n.y, n.z, 0.0],
            [q.x, q.y, q.z, 1.0],
        ];
        assert_eq!(view_to_world(&cam).to_cols_array_2d(), inv);
        for (r, row) in m.iter().enumerate() {
            let prod = row_times(*row, inv);
            for (c, x) in prod.iter().enumerate() {
                let id = if r == c { 1.0 } else { 0.0 };
                assert!((x - id).abs() < 1e-14, "M·M⁻¹[{r}][{c}] = {x}");
            }
        }
    }

    #[test]
    fn parallel_vpn_vuv_is_an_error_without_a_previous_frame() {
        assert_eq!(
            Basis::from_vpn_vuv(DVec3::Y, DVec3::Y * 2.0),
            Err(CameraError::Parallel)
        );
        assert_eq!(
            Basis::from_vpn_vuv(DVec3::ZERO, DVec3::Y),
            Err(CameraError::ZeroVpn)
        );
        assert_eq!(
            Basis::from_vpn_vuv(DVec3::Z, DVec3::ZERO),
            Err(CameraError::ZeroVuv)
        );
        assert_eq!(
            Basis::from_vpn_vuv(DVec3::new(f64::NAN, 0.0, 1.0), DVec3::Y),
            Err(CameraError::ZeroVpn)
        );
    }

    #[test]
    fn parallel_vpn_vuv_follows_the_previous_v() {
        let b = Basis::following(-DVec3::Y, DVec3::Y, Some(DVec3::Z)).unwrap();
        assert_eq!(b.v, DVec3::Z);
        // u = n × v = (−y) × z = −x.
        assert_eq!(b.u, DVec3::new(-1.0, 0.0, 0.0));
    }

    #[test]
    fn window_point_matches_the_pixel_formula() {
        let w = DVec2::new(1.6, 0.9);
        let p = window_point(w, (640, 360), 0.5, 0.5);
        assert_eq!(
            p,
            DVec3::new(0.5 / 640.0 * 1.6 - 0.8, 0.45 - 0.5 / 360.0 * 0.9, 0.0)
        );
        let c = window_point(w, (640, 360), 320.0, 180.0);
        assert_eq!(c, DVec3::ZERO);
    }

    fn finite_vec() -> impl Strategy<Value = DVec3> {
        (-100.0f64..100.0, -100.0f64..100.0, -100.0f64..100.0)
            .prop_map(|(x, y, z)| DVec3::new(x, y, z))
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 512, rng_seed: proptest::test_runner::RngSeed::Fixed(0x5eed), failure_persistence: None, ..ProptestConfig::default() })]

        #[test]
        fn basis_is_orthonormal_and_left_handed(vpn in finite_vec(), vuv in finite_vec()) {
            prop_assume!(vpn.length() > 1e-3 && vuv.length() > 1e-3);
            prop_assume!(vpn.normalize().cross(vuv.normalize()).length() > 1e-6);
            let b = Basis::from_vpn_vuv(vpn, vuv).unwrap();
            for (a, c) in [(b.u, b.v), (b.v, b.n), (b.n, b.u)] {
                prop_assert!(a.dot(c).abs() < 1e-12);
            }
            for a in [b.u, b.v, b.n] {
                prop_assert!((a.length() - 1.0).abs() < 1e-12);
            }
            // Left-handed: v = u × n, so u · (v × n) = −1 … written without the code's formula:
            // the determinant of (u, v, n) is −1.
            let det = b.u.x * (b.v.y * b.n.z - b.v.z * b.n.y) - b.u.y * (b.v.x * b.n.z - b.v.z * b.n.x)
                + b.u.z * (b.v.x * b.n.y - b.v.y * b.n.x);
            prop_assert!((det + 1.0).abs() < 1e-12);
            // v lies in the plane of VUV and n, on VUV's side.
            prop_assert!(b.v.dot(vuv) > 0.0);
            prop_assert!((vpn.normalize() - b.n).length() < 1e-12);
        }

        #[test]
        fn world_view_round_trip(vrp in finite_vec(), vpn in finite_vec(), p in finite_vec()) {
            prop_assume!(vpn.length() > 1e-3 && vpn.normalize().cross(DVec3::Y).length() > 1e-6);
            let cam = camera(vrp, vpn, DVec3::Y);
            let m = cam.world_to_view() * view_to_world(&cam);
            prop_assert!(m.abs_diff_eq(DMat4::IDENTITY, 1e-12));
            let view = cam.world_to_view().transform_point3(p);
            prop_assert!((view - cam.point_to_view(p)).length() < 1e-9);
            prop_assert!((cam.point_to_world(view) - p).length() < 1e-9);
        }
    }
}

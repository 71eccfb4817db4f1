//! Inertial parameters of one rigid body in its link frame (paper eqs. 5, 9-10, 18, 20).

use nalgebra::{Matrix3, Matrix4, SVector, Vector3};

use crate::error::{DynamicsError, check_finite_slice};
use crate::spatial::{Force, Motion};

/// Inertial parameters of one rigid body, expressed in its link (DH) frame.
///
/// This is the linear parametrisation of the paper (eqs. 9-10): mass, first moment m·c and the
/// inertia tensor J about the link-frame origin. Torques are linear in these ten numbers.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct InertialParameters {
    /// Mass m, kg.
    pub mass: f64,
    /// First moment of mass m·c, kg·m, in the link frame (c = centre of mass).
    pub first_moment: Vector3<f64>,
    /// Inertia tensor about the link-frame origin, kg·m², in the link frame (the paper's J);
    /// products of inertia follow the tensor convention (J_xy is the (0,1) entry, = −∫xy dm).
    pub inertia_origin: Matrix3<f64>,
}

/// Skew-symmetric matrix S(v) with S(v)·w = v × w.
pub(crate) fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

impl InertialParameters {
    /// The massless body (all ten parameters zero).
    pub fn zero() -> Self {
        Self {
            mass: 0.0,
            first_moment: Vector3::zeros(),
            inertia_origin: Matrix3::zeros(),
        }
    }

    /// Body of `mass` kg with centre of mass `com` (m, link frame) and inertia `inertia_about_com`
    /// (kg·m², about the CoM, axes parallel to the link frame); Steiner's theorem (eq. 18) moves
    /// the inertia to the link-frame origin.
    pub fn from_com(mass: f64, com: Vector3<f64>, inertia_about_com: Matrix3<f64>) -> Self {
        let s = skew(&com);
        Self {
            mass,
            first_moment: com * mass,
            inertia_origin: inertia_about_com + s.transpose() * s * mass,
        }
    }

    /// Point mass of `mass` kg at `com` (m, link frame), with no inertia about its own CoM.
    pub fn point_mass(mass: f64, com: Vector3<f64>) -> Self {
        Self::from_com(mass, com, Matrix3::zeros())
    }

    /// Centre of mass in the link frame, m; `None` when the mass is zero.
    pub fn com(&self) -> Option<Vector3<f64>> {
        if self.mass == 0.0 {
            None
        } else {
            Some(self.first_moment / self.mass)
        }
    }

    /// Inertia tensor about the centre of mass (axes of the link frame), kg·m²; equals
    /// `inertia_origin` for a massless body.
    pub fn inertia_about_com(&self) -> Matrix3<f64> {
        if self.mass == 0.0 {
            return self.inertia_origin;
        }
        // J_c = J_o − m S(c)ᵀS(c) = J_o + S(h)S(h)/m
        let s = skew(&self.first_moment);
        self.inertia_origin + s * s / self.mass
    }

    /// The ten parameters (m, mcx, mcy, mcz, Jxx, Jxy, Jxz, Jyy, Jyz, Jzz) of eqs. 9-10 and 20;
    /// units kg, kg·m, kg·m².
    pub fn to_vector(&self) -> SVector<f64, 10> {
        let h = &self.first_moment;
        let j = &self.inertia_origin;
        SVector::<f64, 10>::from_column_slice(&[
            self.mass,
            h.x,
            h.y,
            h.z,
            j[(0, 0)],
            j[(0, 1)],
            j[(0, 2)],
            j[(1, 1)],
            j[(1, 2)],
            j[(2, 2)],
        ])
    }

    /// Inverse of [`InertialParameters::to_vector`]; the tensor is built symmetric.
    pub fn from_vector(v: &SVector<f64, 10>) -> Self {
        Self {
            mass: v[0],
            first_moment: Vector3::new(v[1], v[2], v[3]),
            inertia_origin: Matrix3::new(v[4], v[5], v[6], v[5], v[7], v[8], v[6], v[8], v[9]),
        }
    }

    /// Parameters of this body plus another body expressed in the same frame (eqs. 16-19, 17).
    pub fn plus(&self, other: &InertialParameters) -> Self {
        Self {
            mass: self.mass + other.mass,
            first_moment: self.first_moment + other.first_moment,
            inertia_origin: self.inertia_origin + other.inertia_origin,
        }
    }

    /// The same body expressed in a frame F, given this body's frame pose in F (rotation
    /// `rotation`, origin `translation` in m): c_F = R·c + p, J moved with Steiner.
    pub fn transformed(&self, rotation: &Matrix3<f64>, translation: &Vector3<f64>) -> Self {
        let r = rotation;
        let h_rot = r * self.first_moment;
        let p = translation;
        // J_F = R J Rᵀ − m S(p)² − S(p)S(Rh) − S(Rh)S(p), with S(a)S(b) = b aᵀ − (a·b) 1 and
        // w = Rh + m p / 2:  J_F = R J Rᵀ + 2 (p·w) 1 − p wᵀ − w pᵀ.
        let w = h_rot + p * (0.5 * self.mass);
        let diagonal = 2.0 * p.dot(&w);
        // R J Rᵀ is symmetric: form J Rᵀ, then only the upper triangle of R (J Rᵀ).
        let jrt = self.inertia_origin * r.transpose();
        let entry = |i: usize, k: usize| {
            r[(i, 0)] * jrt[(0, k)] + r[(i, 1)] * jrt[(1, k)] + r[(i, 2)] * jrt[(2, k)]
                - p[i] * w[k]
                - w[i] * p[k]
        };
        let (xx, yy, zz) = (
            entry(0, 0) + diagonal,
            entry(1, 1) + diagonal,
            entry(2, 2) + diagonal,
        );
        let (xy, xz, yz) = (entry(0, 1), entry(0, 2), entry(1, 2));
        Self {
            mass: self.mass,
            first_moment: translation * self.mass + h_rot,
            inertia_origin: Matrix3::new(xx, xy, xz, xy, yy, yz, xz, yz, zz),
        }
    }

    /// The pseudo-inertia [[Σ, h], [hᵀ, m]]: Σ = ½tr(J)·1 − J the second moment about the
    /// link origin (kg·m²), h = m·c (kg·m), m (kg). Positive definite exactly when the ten
    /// parameters are a realisable rigid body (Wensing, Kim & Slotine 2017).
    pub fn pseudo_inertia(&self) -> Matrix4<f64> {
        let j = &self.inertia_origin;
        let sigma = Matrix3::identity() * (0.5 * j.trace()) - j;
        let mut p = Matrix4::zeros();
        p.fixed_view_mut::<3, 3>(0, 0).copy_from(&sigma);
        for i in 0..3 {
            p[(i, 3)] = self.first_moment[i];
            p[(3, i)] = self.first_moment[i];
        }
        p[(3, 3)] = self.mass;
        p
    }

    /// The smallest eigenvalue of [`InertialParameters::pseudo_inertia`], kg·m² (> 0: a
    /// realisable body).
    pub fn smallest_pseudo_eigenvalue(&self) -> f64 {
        self.pseudo_inertia()
            .symmetric_eigenvalues()
            .iter()
            .copied()
            .fold(f64::INFINITY, f64::min)
    }

    /// Checks that the parameters describe a real rigid body: finite, mass ≥ 0, symmetric tensor,
    /// inertia about the CoM positive semidefinite and satisfying the triangle inequality.
    pub fn check_physical(&self) -> Result<(), DynamicsError> {
        check_finite_slice("mass", &[self.mass])?;
        check_finite_slice("first_moment", self.first_moment.as_slice())?;
        check_finite_slice("inertia_origin", self.inertia_origin.as_slice())?;
        if self.mass < 0.0 {
            return Err(DynamicsError::NegativeMass { mass: self.mass });
        }
        let scale = self.inertia_origin.abs().max().max(f64::MIN_POSITIVE);
        let asymmetry = (self.inertia_origin - self.inertia_origin.transpose())
            .abs()
            .max();
        if asymmetry > 1e-12 * scale {
            return Err(DynamicsError::InertiaNotSymmetric { asymmetry });
        }
        if self.mass == 0.0 && self.first_moment != Vector3::zeros() {
            return Err(DynamicsError::FirstMomentWithoutMass {
                first_moment: [
                    self.first_moment.x,
                    self.first_moment.y,
                    self.first_moment.z,
                ],
            });
        }
        let about_com = self.inertia_about_com();
        let sym = (about_com + about_com.transpose()) * 0.5;
        let mut moments = sym.symmetric_eigenvalues();
        moments
            .as_mut_slice()
            .sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
        let principal_moments = [moments[0], moments[1], moments[2]];
        // Rounding in the Steiner shift is relative to the inertia about the origin.
        let tolerance = 1e-10 * scale;
        if moments[0] < -tolerance {
            return Err(DynamicsError::InertiaNotPositive { principal_moments });
        }
        if moments[0] + moments[1] < moments[2] - tolerance {
            return Err(DynamicsError::TriangleInequality { principal_moments });
        }
        Ok(())
    }

    /// Rate of change of these parameters, expressed in a fixed frame, while the body moves with
    /// spatial velocity `v` (same frame): İ = v ×* I − I v×, as parameters with zero mass rate
    /// (kg·m/s and kg·m²/s). With r' = v_O + ω × r for every body point:
    /// ḣ = ω × h + m v_O and J̇ = [ω]J − J[ω] + 2 (v_O·h) 1 − h v_Oᵀ − v_O hᵀ.
    #[inline]
    pub(crate) fn rate(&self, v: &Motion) -> Self {
        let (w, u) = (&v.ang, &v.lin);
        let h = &self.first_moment;
        let j = &self.inertia_origin;
        // [ω]J column by column; −J[ω] is its transpose because J is symmetric.
        let wj = Matrix3::from_columns(&[
            w.cross(&j.column(0).into_owned()),
            w.cross(&j.column(1).into_owned()),
            w.cross(&j.column(2).into_owned()),
        ]);
        let uh = u * h.transpose();
        Self {
            mass: 0.0,
            first_moment: w.cross(h) + u * self.mass,
            inertia_origin: wj + wj.transpose() - uh - uh.transpose()
                + Matrix3::from_diagonal_element(2.0 * u.dot(h)),
        }
    }

    /// Spatial momentum-type product I·v (moment about the frame origin; force), in this frame.
    #[inline]
    pub(crate) fn apply(&self, v: &Motion) -> Force {
        // n = J ω + h × v ; f = m v − h × ω
        Force {
            ang: self.inertia_origin * v.ang + self.first_moment.cross(&v.lin),
            lin: v.lin * self.mass - self.first_moment.cross(&v.ang),
        }
    }
}

//! The paper's coefficient-set workflow (eqs. 21–25, 27–28): from identified dynamic
//! coefficients without (π̂) and with (π̂_L) the payload, estimate the payload parameters.
//!
//! # Coefficient-set file format
//!
//! A plain-text file, one directive per line, `#` starts a comment:
//!
//! ```text
//! # Planar 2R robot, Gaz & De Luca 2017, eq. (29)
//! links 2                              # number of links n; the payload sits on link n
//! const a1 = 1.0                       # named constant (m), usable in later lines
//! const a2 = 0.5
//! payload m, mcx, mcy, Jzz             # payload parameters to estimate, in output order
//! coef pi1 = 0.5*(m2*a2^2 + J2zz) + a2*c2x*m2
//! coef pi2 = c2x*m2 + a2*m2
//! ```
//!
//! Each `coef` line defines one coefficient, in order, as a linear combination of link
//! parameters (syntax in [`crate::expr`]: `m<i>`, `c<i>x·m<i>`, `mc<i>x`, `J<i>xx`, … with inertia
//! about the link-frame origin). Written without payload symbols, the definitions describe the
//! unloaded robot, and the payload is substituted into link n as in eqs. (16)–(19):
//! m_n → m_n + m_L, m_n c_n → m_n c_n + m_L c_L, J_n → J_n + J_L. Written with payload symbols
//! (`mL`, `cLx*mL`, `JLzz`, as in eqs. 30 and 38), the definitions are π_L as printed and are
//! used without substitution. Either way J_ε = ∂ε/∂p_L (eq. 27) is derived numerically from the
//! definitions; nothing is hand-written.
//!
//! `payload` names slots of the payload's 10-vector (`m mcx mcy mcz Jxx Jxy Jxz Jyy Jyz Jzz`).
//! Every payload parameter that changes a coefficient must be listed.

use std::collections::BTreeMap;

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::error::EstimatorError;
use crate::expr::{self, Body, LinearForm, ParamSlot, SLOT_NAMES};
use crate::lsq;

/// Definition of the planar 2R robot's coefficient vector π, paper eq. (29).
pub const PLANAR_2R: &str = "\
# Planar 2R robot of Gaz & De Luca (IROS 2017), Sec. IV, eq. (29).
# Classical DH frames; frame i at the tip of link i; J about the frame origin; gravity along -y.
links 2
const a1 = 1.0   # m
const a2 = 0.5   # m
payload m, mcx, mcy, Jzz   # eq. (33)
coef pi1 = 0.5*(m2*a2^2 + J2zz) + a2*c2x*m2
coef pi2 = c2x*m2 + a2*m2
coef pi3 = c2y*m2
coef pi4 = 0.5*(J1zz + a1^2*m1 + a1^2*m2) + a1*c1x*m1
coef pi5 = c1x*m1 + a1*m1 + a1*m2
coef pi6 = c1y*m1
";

/// Definition of the KUKA LWR 4+ gravity coefficients π_g, paper eq. (38) without payload.
pub const LWR4_GRAVITY: &str = "\
# KUKA LWR 4+ gravity coefficients pi_g of Gaz & De Luca (IROS 2017), eq. (38), classical DH.
# The payload is substituted into link 7 (eqs. 16-19), which gives eq. (38) as printed.
links 7
const d1 = 0.4    # m, DH d3
const d2 = 0.39   # m, DH d5
payload m, mcx, mcy, mcz   # eq. (40)
coef pg1 = c7y*m7
coef pg2 = c7x*m7
coef pg3 = c6x*m6
coef pg4 = c6z*m6 + c7z*m7
coef pg5 = c5z*m5 - c6y*m6
coef pg6 = c5x*m5
coef pg7 = c5y*m5 + c4z*m4 + d2*(m5 + m6 + m7)
coef pg8 = c4x*m4
coef pg9 = c4y*m4 + c3z*m3
coef pg10 = c2x*m2
coef pg11 = c3x*m3
coef pg12 = c2z*m2 - c3y*m3 + d1*(m3 + m4 + m5 + m6 + m7)
";

/// Largest link count a coefficient set may declare; far beyond any serial arm, and it keeps a
/// damaged `links` line from sizing the per-link parameter vectors out of memory.
pub const MAX_LINKS: usize = 1000;

/// A parsed coefficient set: the symbolic definition of a robot's dynamic coefficients.
#[derive(Debug, Clone)]
pub struct CoefficientSet {
    /// Number of robot links n (the payload is attached to link n).
    pub links: usize,
    /// Named constants (units as written, usually m).
    pub constants: BTreeMap<String, f64>,
    /// Coefficient names and their linear forms, in file order.
    pub coefficients: Vec<(String, LinearForm)>,
    /// Estimated payload parameter slots (indices into the 10-vector), in output order.
    pub payload_slots: Vec<ParamSlot>,
    /// True when the definitions contain payload symbols (π_L written out, no substitution).
    pub explicit_payload: bool,
}

fn syntax(line: usize, message: impl Into<String>) -> EstimatorError {
    EstimatorError::CoefficientSyntax {
        line,
        message: message.into(),
    }
}

impl CoefficientSet {
    /// Parses a coefficient-set definition (format in the module docs).
    pub fn parse(text: &str) -> Result<Self, EstimatorError> {
        let mut links: Option<usize> = None;
        let mut constants = BTreeMap::new();
        let mut coefficients: Vec<(String, LinearForm)> = Vec::new();
        let mut payload_slots: Option<Vec<ParamSlot>> = None;
        for (idx, raw) in text.lines().enumerate() {
            let line_no = idx + 1;
            let line = raw.split('#').next().unwrap_or("").trim();
            if line.is_empty() {
                continue;
            }
            let (keyword, rest) = line.split_once(char::is_whitespace).unwrap_or((line, ""));
            let rest = rest.trim();
            match keyword {
                "links" => {
                    let n: usize = rest.parse().map_err(|_| {
                        syntax(
                            line_no,
                            format!("`links` needs a positive integer, got `{rest}`"),
                        )
                    })?;
                    if n == 0 || links.is_some() {
                        return Err(syntax(
                            line_no,
                            "`links` must be given once and be at least 1",
                        ));
                    }
                    if n > MAX_LINKS {
                        return Err(syntax(
                            line_no,
                            format!("`links {n}` exceeds the supported {MAX_LINKS} links"),
                        ));
                    }
                    links = Some(n);
                }
                "const" | "coef" => {
                    let n = links.ok_or_else(|| {
                        syntax(line_no, "`links` must come before `const`/`coef`")
                    })?;
                    let (name, body) = rest.split_once('=').ok_or_else(|| {
                        syntax(line_no, format!("expected `{keyword} NAME = EXPRESSION`"))
                    })?;
                    let name = name.trim().to_string();
                    if name.is_empty()
                        || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
                    {
                        return Err(syntax(line_no, format!("bad name `{name}`")));
                    }
                    if keyword == "const" {
                        if expr::is_parameter_symbol(&name, n) || constants.contains_key(&name) {
                            return Err(syntax(
                                line_no,
                                format!(
                                    "constant `{name}` clashes with a parameter symbol or another constant"
                                ),
                            ));
                        }
                        let v = expr::parse_constant(body, &constants)
                            .map_err(|e| syntax(line_no, e.0))?;
                        constants.insert(name, v);
                    } else {
                        let f = expr::parse_linear(body, n, &constants)
                            .map_err(|e| syntax(line_no, e.0))?;
                        if coefficients.iter().any(|(existing, _)| *existing == name) {
                            return Err(syntax(
                                line_no,
                                format!("coefficient `{name}` defined twice"),
                            ));
                        }
                        coefficients.push((name, f));
                    }
                }
                "payload" => {
                    let mut slots = Vec::new();
                    for item in rest
                        .split([',', ' '])
                        .map(str::trim)
                        .filter(|s| !s.is_empty())
                    {
                        let slot = SLOT_NAMES.iter().position(|s| *s == item).ok_or_else(|| {
                            syntax(
                                line_no,
                                format!(
                                    "unknown payload parameter `{item}` (use {})",
                                    SLOT_NAMES.join(" ")
                                ),
                            )
                        })?;
                        if slots.contains(&slot) {
                            return Err(syntax(
                                line_no,
                                format!("payload parameter `{item}` listed twice"),
                            ));
                        }
                        slots.push(slot);
                    }
                    if slots.is_empty() {
                        return Err(syntax(line_no, "`payload` lists no parameter"));
                    }
                    payload_slots = Some(slots);
                }
                other => {
                    return Err(syntax(
                        line_no,
                        format!("unknown directive `{other}` (use links, const, payload, coef)"),
                    ));
                }
            }
        }
        let links = links.ok_or_else(|| syntax(0, "missing `links N`"))?;
        if coefficients.is_empty() {
            return Err(syntax(0, "no `coef` line"));
        }
        let payload_slots = payload_slots.unwrap_or_else(|| (0..10).collect());
        let explicit_payload = coefficients
            .iter()
            .any(|(_, f)| f.keys().any(|(b, _)| *b == Body::Payload));
        let set = CoefficientSet {
            links,
            constants,
            coefficients,
            payload_slots,
            explicit_payload,
        };
        // every payload parameter that moves a coefficient must be estimated
        let full = set.full_payload_jacobian();
        for (slot, name) in SLOT_NAMES.iter().enumerate() {
            if !set.payload_slots.contains(&slot) && full.column(slot).iter().any(|v| *v != 0.0) {
                return Err(syntax(
                    0,
                    format!(
                        "payload parameter `{name}` changes the coefficients but is not listed in `payload`"
                    ),
                ));
            }
        }
        Ok(set)
    }

    /// A built-in set by name: `planar-2r` (eq. 29) or `lwr4-gravity` (eq. 38).
    pub fn builtin(name: &str) -> Option<Self> {
        let text = match name {
            "planar-2r" => PLANAR_2R,
            "lwr4-gravity" => LWR4_GRAVITY,
            _ => return None,
        };
        Self::parse(text).ok()
    }

    /// Names of the coefficients, in order.
    pub fn names(&self) -> Vec<&str> {
        self.coefficients.iter().map(|(n, _)| n.as_str()).collect()
    }

    /// Names of the estimated payload parameters, in output order.
    pub fn payload_names(&self) -> Vec<&'static str> {
        self.payload_slots.iter().map(|s| SLOT_NAMES[*s]).collect()
    }

    /// Evaluates π_L for link parameter vectors `links` (10 each, frame i) and payload `payload`
    /// (10, last frame); payload substitution follows eqs. (16)–(19) unless the set is explicit.
    pub fn evaluate(
        &self,
        links: &[[f64; 10]],
        payload: &[f64; 10],
    ) -> Result<DVector<f64>, EstimatorError> {
        if links.len() != self.links {
            return Err(EstimatorError::CoefficientData(format!(
                "{} link parameter vectors given, the set has {} links",
                links.len(),
                self.links
            )));
        }
        let mut bodies = links.to_vec();
        let mut payload_body = [0.0; 10];
        if self.explicit_payload {
            payload_body = *payload;
        } else if let Some(last) = bodies.last_mut() {
            for (x, p) in last.iter_mut().zip(payload) {
                *x += p;
            }
        }
        Ok(DVector::from_iterator(
            self.coefficients.len(),
            self.coefficients.iter().map(|(_, f)| {
                f.iter()
                    .map(|((body, slot), k)| {
                        let v = match body {
                            Body::Link(i) => bodies[*i][*slot],
                            Body::Payload => payload_body[*slot],
                        };
                        k * v
                    })
                    .sum::<f64>()
            }),
        ))
    }

    /// ∂ε/∂p_L for all 10 payload parameters, derived by evaluating ε(p_L) = π_L(p, p_L) − π_L(p, 0)
    /// at unit payload vectors (exact: ε is linear in p_L).
    fn full_payload_jacobian(&self) -> DMatrix<f64> {
        let zero_links = vec![[0.0; 10]; self.links];
        let base = self.evaluate(&zero_links, &[0.0; 10]);
        let mut j = DMatrix::zeros(self.coefficients.len(), 10);
        if let Ok(base) = base {
            for slot in 0..10 {
                let mut unit = [0.0; 10];
                unit[slot] = 1.0;
                if let Ok(v) = self.evaluate(&zero_links, &unit) {
                    j.set_column(slot, &(v - &base));
                }
            }
        }
        j
    }

    /// The payload Jacobian J_ε (eq. 27): rows per coefficient, columns per estimated payload
    /// parameter (units: coefficient unit per parameter unit).
    pub fn payload_jacobian(&self) -> DMatrix<f64> {
        let full = self.full_payload_jacobian();
        DMatrix::from_fn(full.nrows(), self.payload_slots.len(), |r, c| {
            full[(r, self.payload_slots[c])]
        })
    }

    /// 0-based indices of the coefficients that the payload changes (non-zero rows of J_ε).
    pub fn nonzero_rows(&self) -> Vec<usize> {
        let j = self.payload_jacobian();
        (0..j.nrows())
            .filter(|&r| j.row(r).iter().any(|v| v.abs() > 1e-14))
            .collect()
    }

    /// Estimates p_L from unloaded and loaded coefficient vectors (eqs. 25 and 28).
    pub fn estimate(
        &self,
        unloaded: &[f64],
        loaded: &[f64],
    ) -> Result<CoefficientEstimate, EstimatorError> {
        let n = self.coefficients.len();
        for (label, v) in [("unloaded", unloaded), ("loaded", loaded)] {
            if v.len() != n {
                return Err(EstimatorError::CoefficientData(format!(
                    "the {label} vector has {} elements, the set defines {n} coefficients ({})",
                    v.len(),
                    self.names().join(", ")
                )));
            }
            if let Some(i) = v.iter().position(|x| !x.is_finite()) {
                return Err(EstimatorError::CoefficientData(format!(
                    "{label} element {} is not finite",
                    i + 1
                )));
            }
        }
        let eps: Vec<f64> = loaded.iter().zip(unloaded).map(|(l, u)| l - u).collect();
        self.estimate_from_difference(&eps)
    }

    /// Estimates p_L from a numerical difference vector ε̂ (eq. 26 or 25), p̂_L = J_ε,nz^# ε̂_nz (eq. 28).
    pub fn estimate_from_difference(
        &self,
        epsilon: &[f64],
    ) -> Result<CoefficientEstimate, EstimatorError> {
        if epsilon.len() != self.coefficients.len() {
            return Err(EstimatorError::CoefficientData(format!(
                "ε has {} elements, the set defines {} coefficients",
                epsilon.len(),
                self.coefficients.len()
            )));
        }
        let rows = self.nonzero_rows();
        let j = self.payload_jacobian();
        let j_nz = DMatrix::from_fn(rows.len(), j.ncols(), |r, c| j[(rows[r], c)]);
        let eps_nz = DVector::from_iterator(rows.len(), rows.iter().map(|&r| epsilon[r]));
        let pinv = lsq::pseudo_inverse(&j_nz, 1e10)?;
        let p = &pinv * &eps_nz;
        let p_l: Vec<f64> = p.iter().copied().collect();
        let mass = self
            .payload_slots
            .iter()
            .position(|s| *s == 0)
            .map(|i| p_l[i]);
        let mut com = [None; 3];
        if let Some(m) = mass.filter(|m| *m > 0.0) {
            for (axis, c) in com.iter_mut().enumerate() {
                if let Some(i) = self.payload_slots.iter().position(|s| *s == 1 + axis) {
                    *c = Some(p_l[i] / m);
                }
            }
        }
        Ok(CoefficientEstimate {
            epsilon: epsilon.to_vec(),
            nonzero_rows: rows.iter().map(|r| r + 1).collect(),
            jacobian_nonzero: (0..j_nz.nrows())
                .map(|r| j_nz.row(r).iter().copied().collect())
                .collect(),
            p_l_names: self.payload_names().iter().map(|s| s.to_string()).collect(),
            p_l,
            mass,
            com,
        })
    }
}

/// Result of the coefficient workflow, in the set's payload-parameter order.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CoefficientEstimate {
    /// ε̂ = π̂_L − π̂ for every coefficient (units of the coefficients).
    pub epsilon: Vec<f64>,
    /// 1-based indices of the coefficients the payload changes (non-zero rows of J_ε).
    pub nonzero_rows: Vec<usize>,
    /// J_ε restricted to the non-zero rows (row-major).
    pub jacobian_nonzero: Vec<Vec<f64>>,
    /// Names of the estimated payload parameters (`m`, `mcx`, …, `Jzz`).
    pub p_l_names: Vec<String>,
    /// Estimated payload parameters p̂_L (kg, kg·m, kg·m²), in `p_l_names` order.
    pub p_l: Vec<f64>,
    /// Estimated mass in kg, when `m` is estimated.
    pub mass: Option<f64>,
    /// Estimated CoM in the last link frame, m; `None` for axes whose first moment is not estimated.
    pub com: [Option<f64>; 3],
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn planar_2r_reproduces_the_robot_coefficients() {
        // lwr4-model.md §7: π = (0.11125, 0.6, 0.04, 1.36515, 3.2, 0.03), with payload (0.6144, 1.8, 0.19, 2.11515, 4.7, 0.03)
        let set = CoefficientSet::builtin("planar-2r").unwrap();
        let link = |m: f64, cx: f64, cy: f64, jzz: f64| {
            let mut v = [0.0; 10];
            v[0] = m;
            v[1] = m * cx;
            v[2] = m * cy;
            v[9] = jzz;
            v
        };
        let links = [link(3.0, -0.6, 0.01, 1.3303), link(2.0, -0.2, 0.02, 0.1225)];
        let pi = set.evaluate(&links, &[0.0; 10]).unwrap();
        let expect = [0.11125, 0.6, 0.04, 1.36515, 3.2, 0.03];
        for (a, b) in pi.iter().zip(expect) {
            assert!((a - b).abs() < 1e-12, "{pi}");
        }
        let payload = link(1.5, 0.3, 0.1, 0.1813);
        let pi_l = set.evaluate(&links, &payload).unwrap();
        let expect_l = [0.6144, 1.8, 0.19, 2.11515, 4.7, 0.03];
        for (a, b) in pi_l.iter().zip(expect_l) {
            assert!((a - b).abs() < 1e-4, "{pi_l}");
        }
    }

    #[test]
    fn planar_2r_jacobian_is_eq_32() {
        let set = CoefficientSet::builtin("planar-2r").unwrap();
        assert_eq!(set.nonzero_rows(), vec![0, 1, 2, 3, 4]);
        let j = set.payload_jacobian();
        let expect = [
            [0.125, 0.5, 0.0, 0.5],
            [0.5, 1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
            [0.5, 0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, 0.0, 0.0],
        ];
        for (r, row) in expect.iter().enumerate() {
            for (c, v) in row.iter().enumerate() {
                assert!((j[(r, c)] - v).abs() < 1e-15, "J[{r},{c}] = {}", j[(r, c)]);
            }
        }
    }

    #[test]
    fn lwr4_jacobian_has_the_papers_nonzero_rows() {
        let set = CoefficientSet::builtin("lwr4-gravity").unwrap();
        // components 1, 2, 4, 7 and 12 (eq. 43)
        assert_eq!(set.nonzero_rows(), vec![0, 1, 3, 6, 11]);
        let j = set.payload_jacobian();
        assert_eq!(j[(0, 2)], 1.0);
        assert_eq!(j[(1, 1)], 1.0);
        assert_eq!(j[(3, 3)], 1.0);
        assert!((j[(6, 0)] - 0.39).abs() < 1e-15);
        assert!((j[(11, 0)] - 0.4).abs() < 1e-15);
    }

    #[test]
    fn explicit_payload_symbols_give_the_same_jacobian() {
        let text =
            "links 2\nconst a2 = 0.5\npayload m, mcx\ncoef p1 = c2x*m2 + cLx*mL + a2*(m2 + mL)\n";
        let set = CoefficientSet::parse(text).unwrap();
        assert!(set.explicit_payload);
        let j = set.payload_jacobian();
        assert_eq!((j[(0, 0)], j[(0, 1)]), (0.5, 1.0));
    }

    #[test]
    fn missing_payload_parameter_is_rejected() {
        let text = "links 1\npayload m\ncoef p1 = c1x*m1\n";
        let err = CoefficientSet::parse(text).unwrap_err().to_string();
        assert!(err.contains("mcx"), "{err}");
    }

    #[test]
    fn syntax_errors_name_the_line() {
        let err = CoefficientSet::parse("links 2\n\ncoef p1 = m1 * m2\n")
            .unwrap_err()
            .to_string();
        assert!(err.contains("line 3"), "{err}");
        assert!(CoefficientSet::parse("coef p = m1\n").is_err());
        assert!(CoefficientSet::parse("links 2\nfoo bar\n").is_err());
    }
}

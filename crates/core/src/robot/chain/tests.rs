use nalgebra::{DMatrix, DVector, Isometry3, Translation3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::*;
use crate::math::numdiff::central_diff;
use crate::math::so3::rvec_from_rotation;
use crate::robot::Irb1200;

fn random_q(rng: &mut ChaCha8Rng, limits: &[[f64; 2]]) -> Vec<f64> {
    limits.iter().map(|[lo, hi]| rng.random_range(lo.max(-7.0)..hi.min(7.0))).collect()
}

#[test]
fn irb1200_urdf_equals_the_product_of_exponentials() {
    let urdf = SerialChain::from_urdf(IRB1200_URDF, "base_link", "tool0").expect("urdf");
    let poe = Irb1200;
    assert_eq!(urdf.dof(), 6);
    assert_eq!(urdf.limits_rad(), poe.limits_rad());
    assert_eq!(urdf.velocity_limits(), poe.velocity_limits());
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for _ in 0..200 {
        let q = random_q(&mut rng, &poe.limits_rad());
        let (a, b) = (urdf.base_from_tool(&q).expect("fk"), poe.base_from_tool(&q).expect("fk"));
        assert!((a.to_homogeneous() - b.to_homogeneous()).abs().max() < 1e-12, "q = {q:?}");
        let (ja, jb) = (urdf.jacobian(&q).expect("jac"), poe.jacobian(&q).expect("jac"));
        assert!((ja - jb).abs().max() < 1e-12, "q = {q:?}");
    }
}

/// UR's standard DH product, written apart from the URDF (the outside reference).
fn ur5e_dh(q: &[f64]) -> Isometry3<f64> {
    let a = [0.0, -0.425, -0.3922, 0.0, 0.0, 0.0];
    let d = [0.1625, 0.0, 0.0, 0.1333, 0.0997, 0.0996];
    let alpha = [std::f64::consts::FRAC_PI_2, 0.0, 0.0, std::f64::consts::FRAC_PI_2, -std::f64::consts::FRAC_PI_2, 0.0];
    (0..6).fold(Isometry3::identity(), |t, i| {
        t * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), q[i])
            * Translation3::new(a[i], 0.0, d[i])
            * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), alpha[i])
    })
}

#[test]
fn ur5e_urdf_equals_the_published_dh_parameters() {
    let ur = SerialChain::from_urdf(UR5E_URDF, "base_link", "tool0").expect("urdf");
    let mut rng = ChaCha8Rng::seed_from_u64(8);
    for _ in 0..200 {
        let q = random_q(&mut rng, &ur.limits_rad());
        let (a, b) = (ur.base_from_tool(&q).expect("fk"), ur5e_dh(&q));
        assert!((a.to_homogeneous() - b.to_homogeneous()).abs().max() < 1e-12, "q = {q:?}");
    }
}

#[test]
fn chain_jacobian_matches_finite_differences() {
    let ur = SerialChain::from_urdf(UR5E_URDF, "base_link", "tool0").expect("urdf");
    for q in [[0.3, -1.2, 1.4, -0.9, -1.5, 0.4], [-2.0, -0.4, 2.1, 0.3, 1.1, -2.5]] {
        let t0 = ur.base_from_tool(&q).expect("fk");
        let f = |x: &DVector<f64>| {
            let t = ur.base_from_tool(x.as_slice()).unwrap_or(t0);
            let w = rvec_from_rotation(&(t.rotation * t0.rotation.inverse()).to_rotation_matrix());
            DVector::from_column_slice(&[w.x, w.y, w.z, t.translation.x, t.translation.y, t.translation.z])
        };
        let num = central_diff(f, &DVector::from_column_slice(&q), 1e-6);
        let ana = ur.jacobian(&q).expect("jac");
        assert!((num - DMatrix::from_column_slice(6, 6, ana.as_slice())).abs().max() < 1e-8);
    }
}

#[test]
fn prismatic_and_continuous_joints() {
    let urdf = r#"<robot name="slide"><link name="a"/><link name="b"/><link name="c"/>
        <joint name="s" type="prismatic"><parent link="a"/><child link="b"/><axis xyz="0 0 2"/><limit lower="0" upper="1" velocity="0.5" effort="1"/></joint>
        <joint name="r" type="continuous"><origin xyz="1 0 0"/><parent link="b"/><child link="c"/><axis xyz="0 0 1"/></joint></robot>"#;
    let c = SerialChain::from_urdf(urdf, "a", "c").expect("urdf");
    assert_eq!(c.limits_rad()[1], [f64::NEG_INFINITY, f64::INFINITY]);
    let t = c.base_from_tool(&[0.25, 0.0]).expect("fk");
    assert!((t.translation.vector - Vector3::new(1.0, 0.0, 0.25)).norm() < 1e-15);
    let j = c.jacobian(&[0.25, 0.3]).expect("jac");
    // The slide moves the tool along z; the turn about the tool's own axis moves it not at all.
    assert_eq!(j.column(0).iter().copied().collect::<Vec<_>>(), vec![0.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
    assert!(j.fixed_view::<3, 1>(3, 1).norm() < 1e-15);
    assert!(matches!(c.check_limits(&[1.5, 0.0]), Err(RobotError::OutOfLimits { joint: 0, .. })));
}

#[test]
fn bad_urdf_and_bad_joint_vectors_are_typed_errors() {
    assert!(matches!(SerialChain::from_urdf("<robot", "a", "b"), Err(RobotError::Urdf(_))));
    assert!(matches!(SerialChain::from_urdf(UR5E_URDF, "base_link", "nowhere"), Err(RobotError::Chain { .. })));
    assert!(matches!(SerialChain::from_urdf(UR5E_URDF, "tool0", "base_link"), Err(RobotError::Chain { .. })));
    let zero_axis = r#"<robot name="z"><link name="a"/><link name="b"/><joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 0"/><limit lower="-1" upper="1" velocity="1" effort="1"/></joint></robot>"#;
    assert!(matches!(SerialChain::from_urdf(zero_axis, "a", "b"), Err(RobotError::Chain { .. })));
    let ur = SerialChain::from_urdf(UR5E_URDF, "base_link", "tool0").expect("urdf");
    assert!(matches!(ur.base_from_tool(&[0.0; 5]), Err(RobotError::JointCount { expected: 6, got: 5, .. })));
    assert!(matches!(Irb1200.jacobian(&[0.0; 7]), Err(RobotError::JointCount { expected: 6, got: 7, .. })));
    assert!(matches!(ur.check_limits(&[0.0, f64::NAN, 0.0, 0.0, 0.0, 0.0]), Err(RobotError::NonFinite { joint: 1 })));
}

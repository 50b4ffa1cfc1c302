//! EMVA 1288 measurements on the simulated sensor: photon transfer (sec. 6), non-uniformity
//! from averaged frames (sec. 8), saturation, determinism and validation.

use super::*;

const W: usize = 512;
const H: usize = 512;

/// A 12-bit camera where quantisation does not dominate: K = 0.1 DN/e, 5 e read noise, 20000 e
/// full well (2000 DN), 100 DN black level so that dark frames are not clipped at 0.
fn ptc_model() -> SensorModel {
    SensorModel {
        bit_depth: 12,
        gain_dn_per_e: 0.1,
        read_noise_e: 5.0,
        full_well_e: 20_000.0,
        prnu: 0.01,
        dsnu_e: 2.0,
        black_level_dn: 100.0,
        photons_per_s_at_255: 1.0e7,
        seed: 42,
        ..SensorModel::default()
    }
}

/// One frame of a flat field of constant `grey`, DN as f64.
fn frame(model: &SensorModel, pattern: &FixedPattern, grey: f32, seed: u64) -> Vec<f64> {
    let img = vec![grey; W * H];
    expose(model, pattern, &img, W, H, seed).unwrap().into_iter().map(f64::from).collect()
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

fn variance(v: &[f64]) -> f64 {
    let m = mean(v);
    v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (v.len() - 1) as f64
}

/// EMVA 1288 sec. 6.1: mean of two frames and temporal variance `var(y_A - y_B) / 2`.
fn mean_and_temporal_var(a: &[f64], b: &[f64]) -> (f64, f64) {
    let diff: Vec<f64> = a.iter().zip(b).map(|(x, y)| x - y).collect();
    ((mean(a) + mean(b)) / 2.0, variance(&diff) / 2.0)
}

#[test]
fn photon_transfer_recovers_gain_and_read_noise() {
    let mut model = ptc_model();
    let pattern = FixedPattern::new(&model, W, H).unwrap();
    let sat_dn = model.gain_dn_per_e * model.full_well_e;
    let (mut sxy, mut sxx, mut dark0_var, mut used) = (0.0, 0.0, f64::NAN, 0);
    for k in 0..12u64 {
        model.exposure_s = 4.5e-3 * k as f64 / 11.0;
        let (mu, var) = mean_and_temporal_var(&frame(&model, &pattern, 200.0, 2 * k), &frame(&model, &pattern, 200.0, 2 * k + 1));
        let (mu_d, var_d) = mean_and_temporal_var(&frame(&model, &pattern, 0.0, 100 + 2 * k), &frame(&model, &pattern, 0.0, 101 + 2 * k));
        if k == 0 {
            dark0_var = var_d;
        }
        let (x, y) = (mu - mu_d, var - var_d);
        println!("t = {:.3e} s: mu_y - mu_dark = {x:8.2} DN, sigma_y^2 - sigma_dark^2 = {y:8.3} DN^2", model.exposure_s);
        if x < 0.7 * sat_dn {
            (sxy, sxx, used) = (sxy + x * y, sxx + x * x, used + 1);
        }
    }
    let k_est = sxy / sxx;
    let sigma_d = (dark0_var - 1.0 / 12.0).sqrt() / k_est;
    println!("K = {k_est:.5} DN/e from {used} points, sigma_d = {sigma_d:.4} e");
    assert!(used >= 7, "{used} points below 70 % of saturation");
    assert!((k_est / model.gain_dn_per_e - 1.0).abs() < 0.02, "K = {k_est}");
    assert!((sigma_d / model.read_noise_e - 1.0).abs() < 0.05, "sigma_d = {sigma_d}");
}

/// Mean image of `l` frames and the mean (over pixels) temporal variance of the stack.
fn averaged(model: &SensorModel, pattern: &FixedPattern, grey: f32, l: u64, seed0: u64) -> (Vec<f64>, f64) {
    let frames: Vec<Vec<f64>> = (0..l).map(|i| frame(model, pattern, grey, seed0 + i)).collect();
    let n = l as f64;
    let avg: Vec<f64> = (0..W * H).map(|p| frames.iter().map(|f| f[p]).sum::<f64>() / n).collect();
    let tvar = (0..W * H).map(|p| frames.iter().map(|f| (f[p] - avg[p]).powi(2)).sum::<f64>() / (n - 1.0)).sum::<f64>() / (W * H) as f64;
    (avg, tvar)
}

#[test]
fn prnu_and_dsnu_from_averaged_frames() {
    let mut model = SensorModel { prnu: 0.02, dsnu_e: 3.0, exposure_s: 0.01, ..ptc_model() };
    // 50 % of the 20000 e full well at grey 200.
    model.photons_per_s_at_255 = 0.5 * model.full_well_e / (model.quantum_efficiency * 200.0 / 255.0 * model.exposure_s);
    let pattern = FixedPattern::new(&model, W, H).unwrap();
    let l = 16;
    let (dark, tvar_dark) = averaged(&model, &pattern, 0.0, l, 1000);
    let (half, tvar_half) = averaged(&model, &pattern, 200.0, l, 2000);
    let s2_dark = variance(&dark) - tvar_dark / l as f64;
    let s2_half = variance(&half) - tvar_half / l as f64;
    let k = model.gain_dn_per_e;
    let dsnu = s2_dark.sqrt() / k;
    let prnu = (s2_half - s2_dark).sqrt() / (mean(&half) - mean(&dark));
    println!("DSNU = {dsnu:.4} e, PRNU = {:.4} %, mu_50 - mu_dark = {:.1} DN", 100.0 * prnu, mean(&half) - mean(&dark));
    assert!((mean(&half) - mean(&dark) - 0.5 * k * model.full_well_e).abs() < 0.01 * k * model.full_well_e);
    assert!((dsnu / model.dsnu_e - 1.0).abs() < 0.05, "DSNU = {dsnu}");
    assert!((prnu / model.prnu - 1.0).abs() < 0.05, "PRNU = {prnu}");
}

#[test]
fn mean_dn_follows_the_linear_model() {
    let model = SensorModel { exposure_s: 0.005, black_level_dn: 10.0, ..ptc_model() };
    let pattern = FixedPattern::new(&model, W, H).unwrap();
    for grey in [0.0f32, 50.0, 150.0] {
        let want = expected_dn(&model, f64::from(grey));
        let got = mean(&frame(&model, &pattern, grey, 9));
        assert!((got - want).abs() < 0.01 * want.max(10.0), "grey {grey}: mean {got} DN, model {want} DN");
    }
    assert!((model.mean_electrons(255.0) - 0.6 * 1.0e7 * 0.005).abs() < 1e-6);
    assert_eq!(model.mean_electrons(-5.0), 0.0);
}

#[test]
fn saturation_clips_at_full_well_or_adc_range() {
    let (w, h) = (64, 48);
    let img = vec![255.0f32; w * h];
    let cases = [
        // 8 bits, K = 0.025: the full well (10000 e -> 250 DN) is the limit.
        (SensorModel { exposure_s: 1.0e3, ..SensorModel::default() }, 250),
        // K = 0.05: 500 DN at full well, the ADC clips at 255.
        (SensorModel { exposure_s: 1.0e3, gain_dn_per_e: 0.05, ..SensorModel::default() }, 255),
        // 16 bits, K = 10 DN/e: 1e5 DN at full well, clipped at 65535.
        (SensorModel { exposure_s: 1.0e3, gain_dn_per_e: 10.0, bit_depth: 16, ..SensorModel::default() }, 65535),
    ];
    for (model, want) in cases {
        assert_eq!(want, (model.gain_dn_per_e * model.full_well_e).round().min(f64::from(model.max_dn())) as u16);
        let pattern = FixedPattern::new(&model, w, h).unwrap();
        let dn = expose(&model, &pattern, &img, w, h, 3).unwrap();
        assert!(dn.iter().all(|&v| v == want), "expected {want} DN everywhere, got {:?}", dn.iter().max());
    }
    let m = SensorModel::default();
    assert_eq!((m.max_dn(), SensorModel { bit_depth: 12, ..m }.max_dn(), SensorModel { bit_depth: 16, ..m }.max_dn()), (255, 4095, 65535));
    assert_eq!(dn_to_grey(&m, &[0, 255]), vec![0.0, 255.0]);
    assert_eq!(dn_to_grey(&SensorModel { bit_depth: 12, ..m }, &[4095]), vec![255.0]);
}

#[test]
fn exposure_is_deterministic_and_thread_independent() {
    let (w, h) = (97, 61);
    let model = SensorModel::default();
    let img: Vec<f32> = (0..w * h).map(|i| (i % 256) as f32).collect();
    let pattern = FixedPattern::new(&model, w, h).unwrap();
    assert_eq!(pattern, FixedPattern::new(&model, w, h).unwrap());
    assert_ne!(pattern, FixedPattern::new(&SensorModel { seed: 1, ..model }, w, h).unwrap());
    assert_ne!(pattern.gain[..w], FixedPattern::new(&model, w, h + 1).unwrap().gain[..w]);
    let a = expose(&model, &pattern, &img, w, h, 5).unwrap();
    let one_thread = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let b = one_thread.install(|| expose(&model, &pattern, &img, w, h, 5)).unwrap();
    assert_eq!(a, b);
    let c = expose(&model, &pattern, &img, w, h, 6).unwrap();
    assert!(a.iter().zip(&c).filter(|(x, y)| x != y).count() > w * h / 4);
}

#[test]
fn expose_rejects_bad_buffers() {
    let model = SensorModel::default();
    let pattern = FixedPattern::new(&model, 4, 3).unwrap();
    assert!(matches!(expose(&model, &pattern, &[0.0; 11], 4, 3, 0), Err(SensorError::Size { got: 11, width: 4, height: 3 })));
    assert_eq!(expose(&model, &pattern, &[0.0; 12], 4, 3, 0).map(|v| v.len()), Ok(12));
    assert!(expose(&model, &pattern, &[0.0; 10], 5, 2, 0).is_err());
    let mut img = [1.0f32; 12];
    img[7] = f32::NAN;
    assert!(matches!(expose(&model, &pattern, &img, 4, 3, 0), Err(SensorError::InvalidField { field: "radiance_grey", .. })));
    let empty = FixedPattern::new(&model, 0, 5).unwrap();
    assert_eq!(expose(&model, &empty, &[], 0, 5, 0), Ok(vec![]));
    assert!(FixedPattern::new(&model, usize::MAX, 2).is_err());
    let bad = SensorModel { bit_depth: 9, ..model };
    assert!(FixedPattern::new(&bad, 4, 3).is_err());
    assert!(expose(&bad, &pattern, &[0.0; 12], 4, 3, 0).is_err());
}

fn field_of(m: &SensorModel) -> Option<&'static str> {
    match m.validate() {
        Err(SensorError::InvalidField { field, .. }) => Some(field),
        _ => None,
    }
}

#[test]
fn validate_names_the_field() {
    let d = SensorModel::default();
    assert_eq!(d.validate(), Ok(()));
    let err = SensorModel { exposure_s: -1.0, ..d }.validate().unwrap_err();
    assert!(matches!(&err, SensorError::InvalidField { field: "sensor.exposure_s", .. }));
    assert!(err.to_string().contains("must be >= 0") && err.to_string().contains("sensor.exposure_s"), "{err}");
    let err = SensorModel { full_well_e: 2.0, read_noise_e: 3.0, ..d }.validate().unwrap_err();
    assert!(matches!(&err, SensorError::InvalidField { field: "sensor.full_well_e", .. }));
    assert!(err.to_string().contains("read noise"), "{err}");
    let err = SensorModel { bit_depth: 9, ..d }.validate().unwrap_err();
    assert!(err.to_string().contains("sensor.bit_depth") && err.to_string().contains("must be 8, 10, 12 or 16, got 9"), "{err}");
    assert_eq!(field_of(&SensorModel { quantum_efficiency: 0.0, ..d }), Some("sensor.quantum_efficiency"));
    assert_eq!(field_of(&SensorModel { quantum_efficiency: 1.5, ..d }), Some("sensor.quantum_efficiency"));
    assert_eq!(field_of(&SensorModel { prnu: 1.0, ..d }), Some("sensor.prnu"));
    assert_eq!(field_of(&SensorModel { gain_dn_per_e: 0.0, ..d }), Some("sensor.gain_dn_per_e"));
    assert_eq!(field_of(&SensorModel { black_level_dn: -1.0, ..d }), Some("sensor.black_level_dn"));
    assert_eq!(SensorModel { quantum_efficiency: 1.0, prnu: 0.0, read_noise_e: 0.0, exposure_s: 0.0, ..d }.validate(), Ok(()));
    type Setter = fn(&mut SensorModel);
    let nan_fields: [(&str, Setter); 10] = [
        ("sensor.exposure_s", |m| m.exposure_s = f64::NAN),
        ("sensor.photons_per_s_at_255", |m| m.photons_per_s_at_255 = f64::INFINITY),
        ("sensor.quantum_efficiency", |m| m.quantum_efficiency = f64::NAN),
        ("sensor.full_well_e", |m| m.full_well_e = f64::NAN),
        ("sensor.dark_current_e_per_s", |m| m.dark_current_e_per_s = f64::NAN),
        ("sensor.read_noise_e", |m| m.read_noise_e = f64::NAN),
        ("sensor.prnu", |m| m.prnu = f64::NAN),
        ("sensor.dsnu_e", |m| m.dsnu_e = f64::NAN),
        ("sensor.gain_dn_per_e", |m| m.gain_dn_per_e = f64::NAN),
        ("sensor.black_level_dn", |m| m.black_level_dn = f64::NEG_INFINITY),
    ];
    for (field, set) in nan_fields {
        let mut m = d;
        set(&mut m);
        assert_eq!(field_of(&m), Some(field));
    }
}

#[test]
fn serde_defaults_and_unknown_fields() {
    let m: SensorModel = serde_json::from_str(r#"{"exposure_s": 0.02, "bit_depth": 12}"#).unwrap();
    assert_eq!(m, SensorModel { exposure_s: 0.02, bit_depth: 12, ..SensorModel::default() });
    assert!(serde_json::from_str::<SensorModel>(r#"{"exposure": 0.02}"#).is_err());
}

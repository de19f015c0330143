use contourcheck::machine::MachineConfig;
use contourcheck::plan::AxisCommands;
use contourcheck::sim::{AxisModel, SimConfig, simulate, stickslip};
fn main() {
    let m = AxisModel::from_config(&MachineConfig::default_preset().x);
    for sub in [2, 4, 8, 16] {
        let dt = 0.002;
        let v = 500.0 / 60000.0;
        let n = (4.0 / dt) as usize + 1;
        let cmd = AxisCommands::ramp(0.0, v, dt, n);
        let tr = simulate(
            &m,
            &cmd,
            dt,
            &SimConfig {
                substeps: sub,
                ..Default::default()
            },
        )
        .unwrap();
        let fe: Vec<f64> = (0..tr.len()).map(|k| tr.following_error_m(k)).collect();
        let mut cfg = stickslip::StickSlipConfig::default();
        cfg.sim.substeps = sub;
        let s: Vec<String> = [3.0, 4.0, 4.4, 4.6]
            .iter()
            .map(|f| {
                let r = stickslip::run(&m, f / 60000.0, &cfg).unwrap();
                format!("{f}:{:.4}µm/{}", r.max_counted_slip_m * 1e6, r.stick_slip)
            })
            .collect();
        println!(
            "substeps {sub}: FE(0.1 s) {:.6} µm FE(4 s) {:.6} µm | {}",
            fe[50] * 1e6,
            fe[n - 1] * 1e6,
            s.join(" ")
        );
    }
}

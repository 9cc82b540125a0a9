use std::time::Instant;
fn main() {
    let n: u32 = std::env::args().nth(1).map(|s| s.parse().unwrap()).unwrap_or(1_000_000);
    let curl = std::env::args().nth(2).unwrap_or("analytic".into());
    let text = format!(r#"format = 1
kind = "flow"
[domain]
max = [100.0, 100.0, 100.0]
[time]
duration = 10.0
fps = 30
[flow]
length_scale = 20.0
curl = "{curl}"
substeps = 1
[[flow.obstacles]]
center = [50.0, 50.0, 50.0]
radius = 12.0
influence = 8.0
[[flow.emitters]]
shape = "box"
center = [50.0, 50.0, 50.0]
size = [100.0, 100.0, 100.0]
count = {n}
"#);
    let scene = firn_core::Scene::from_toml_str(&text, "bench.toml").unwrap();
    let mut sim = firn_flow::FlowSimulation::new(scene).unwrap();
    if let Some(s) = std::env::args().nth(3) { sim.set_simd(match s.as_str() { "avx2" => firn_flow::Simd::Avx2, "avx512" => firn_flow::Simd::Avx512, _ => firn_flow::Simd::Portable }); }
    sim.step();
    let steps: u32 = std::env::var("STEPS").ok().and_then(|s| s.parse().ok()).unwrap_or(10);
    let t = Instant::now();
    for _ in 0..steps { sim.step(); }
    let s = t.elapsed().as_secs_f64();
    println!("{:?} n={} {:.2} ns/particle-step, {:.1} steps/s", sim.simd(), n, s*1e9/(steps as f64*n as f64), steps as f64/s);
}

//! The `volcano` binary end to end: the headless render of the main scene is not blank, and
//! bad arguments fail with a message instead of a panic.

use std::process::Command;

fn volcano() -> Command {
    Command::new(env!("CARGO_BIN_EXE_volcano"))
}

#[test]
fn render_eruption_scene_is_not_blank() {
    let dir = std::env::temp_dir().join(format!("volcano-cli-test-{}", std::process::id()));
    let out = dir.join("eruption.png");
    let o = volcano()
        .args(["render", "--scene", "eruption", "--ticks", "10", "--width", "320", "--height", "180"])
        .args(["--min-stddev", "8", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "render failed: {stdout}\n{}", String::from_utf8_lossy(&o.stderr));
    let sd = volcano_test_support::png_pixel_stddev(&out).unwrap();
    assert!(sd > 8.0, "blank frame: std-dev {sd}");
    let (w, h, _) = volcano_test_support::read_png_rgb(&out).unwrap();
    assert_eq!((w, h), (320, 180));
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn bad_arguments_are_errors() {
    let o = volcano().args(["render", "--scene", "atlantis", "--out", "/tmp/x.png"]).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("unknown scene"));
    let o = volcano().args(["render", "--width", "0", "--out", "/tmp/x.png"]).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    // A grid the atmosphere rejects is an error (exit 2), not a silently uncoupled run with an
    // empty summary and exit 0.
    let o = volcano()
        .args([
            "eruption",
            "--scenario",
            "cloud-cap",
            "--seconds",
            "1",
            "--grid",
            "96",
            "--out",
            "/tmp/volcano-grid96",
        ])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("power of two"));
}

#[test]
fn plume_summary_and_threshold() {
    let dir = std::env::temp_dir().join(format!("volcano-plume-test-{}", std::process::id()));
    let o =
        volcano().args(["plume", "--preset", "thesis", "--v0", "200", "--out"]).arg(&dir).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["regime"], "plume");
    let apex = summary["apex_m"].as_f64().unwrap();
    assert!((apex - 10_200.0).abs() < 510.0, "apex {apex}");
    assert!(summary["collapse_altitude_m"].is_null());
    let csv = std::fs::read_to_string(dir.join("trajectory.csv")).unwrap();
    assert!(csv.starts_with("t,x,y,z,vx,vy,vz,r,rho,T,rho_air\n"));
    // One row per 0.1 s over the ≈131 s rise.
    let rows = csv.lines().count() - 1;
    assert!((1_300..1_330).contains(&rows), "{rows} rows");
    let o = volcano().args(["plume-threshold", "--preset", "thesis"]).output().unwrap();
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let t = v["threshold_m_s"].as_f64().unwrap();
    assert!((155.0..165.0).contains(&t), "threshold {t}");
    let o =
        volcano().args(["plume", "--preset", "pyroclastic_showcase", "--out"]).arg(&dir).output().unwrap();
    assert!(o.status.success());
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["regime"], "collapse");
    let o = volcano().args(["plume", "--v0", "-3", "--out"]).arg(&dir).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("v0"));
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn plume_plots_are_written_and_not_blank() {
    let dir = std::env::temp_dir().join(format!("volcano-plots-test-{}", std::process::id()));
    let o = volcano()
        .args(["plume-plots", "--preset", "thesis", "--v0", "200", "--out"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in ["fig3_5a.png", "fig3_5b.png", "fig3_5c.png"] {
        let (w, h, _) = volcano_test_support::read_png_rgb(dir.join(f)).unwrap();
        assert_eq!((w, h), (800, 600));
        let sd = volcano_test_support::png_pixel_stddev(dir.join(f)).unwrap();
        assert!(sd > 5.0, "{f} looks blank: {sd}");
    }
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn plume_export_writes_valid_ply_frames() {
    let dir = std::env::temp_dir().join(format!("volcano-ply-test-{}", std::process::id()));
    let o = volcano()
        .args(["plume", "--preset", "thesis", "--v0", "200", "--frames", "2", "--frame-seconds", "1"])
        .args(["--start-seconds", "3", "--export"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in ["frame_00000.ply", "frame_00001.ply"] {
        let bytes = std::fs::read(dir.join(f)).unwrap();
        let end = bytes.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
        let header = std::str::from_utf8(&bytes[..end]).unwrap();
        assert!(header.starts_with("ply\nformat binary_little_endian 1.0\n"));
        let n: usize =
            header.lines().find_map(|l| l.strip_prefix("element vertex ")).unwrap().parse().unwrap();
        // 3 s at one slice per 0.25 s: ≥ 12 slices × 6 s1 × (1 + 200 s2).
        assert!(n >= 12 * 6 * 201, "{f}: {n} spheres");
        assert_eq!(bytes.len() - end, n * 5 * 4, "5 little-endian f32 per sphere");
        let radius = f32::from_le_bytes(bytes[end + 12..end + 16].try_into().unwrap());
        let density = f32::from_le_bytes(bytes[end + 16..end + 20].try_into().unwrap());
        assert!(radius > 0.0 && density > 0.0 && radius.is_finite() && density.is_finite());
    }
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn bench_times_every_domain_of_the_eruption_scene() {
    let dir = std::env::temp_dir().join(format!("volcano-cli-bench-{}", std::process::id()));
    let o = volcano()
        .args(["bench", "--scene", "eruption", "--ticks", "60", "--out"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(o.status.success(), "bench failed: {}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(dir.join("bench.json")).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(v["ticks"], 60);
    let (p50, p99, max) =
        (v["tick_ms"]["p50"].as_f64(), v["tick_ms"]["p99"].as_f64(), v["tick_ms"]["max"].as_f64());
    let (p50, p99, max) = (p50.unwrap(), p99.unwrap(), max.unwrap());
    assert!(0.0 < p50 && p50 <= p99 && p99 <= max, "{text}");
    // 60 ticks at 50 Hz cross at least one weather step (1 s period) and plenty of others.
    assert!(v["weather_tick_ms_mean"].as_f64().unwrap() > 0.0, "{text}");
    assert!(v["other_tick_ms_mean"].as_f64().unwrap() > 0.0, "{text}");
    // The scene runs a column, an atmosphere with coupling and a lava patch: each set did work.
    for d in ["plume", "weather", "lava", "coupling", "pyroclastic"] {
        let ms = v["domains"][d].as_f64().unwrap_or(-1.0);
        assert!(ms >= 0.0, "{d}: {text}");
    }
    for d in ["plume", "lava", "weather"] {
        assert!(v["domains"][d].as_f64().unwrap() > 0.0, "{d} took no time: {text}");
    }
    // The CPU bill: the process is the main thread and the pools; the main thread spent at
    // least its timed ticks (p50 × ticks) and at most its wall time.
    let cpu = &v["cpu_s_per_sim_s"];
    let (process, main, pools) = (
        cpu["process"].as_f64().unwrap(),
        cpu["main_thread"].as_f64().unwrap(),
        cpu["pools"].as_f64().unwrap(),
    );
    assert!((process - main - pools).abs() < 1e-9 && pools >= 0.0, "{text}");
    // The pools by domain, from each pool thread's own clock: every domain's share is there and
    // they add up to the pools' bill from the process's clock (a pool thread the bench did not
    // find, or a share counted twice, would not).
    let split = cpu["pools_by_domain"].as_object().expect("pools_by_domain on Linux");
    for d in ["plume", "pyroclastic", "coupling", "weather", "lava", "other"] {
        assert!(split.get(d).and_then(|x| x.as_f64()).is_some_and(|x| x >= 0.0), "{d}: {text}");
    }
    let sum: f64 = split.values().filter_map(|x| x.as_f64()).sum();
    assert!((sum - pools).abs() <= 0.05 * pools + 0.01, "split {sum} vs pools {pools}: {text}");
    let ticks_s = 60.0 / 50.0;
    assert!(
        main * ticks_s >= 0.5 * p50 * 60.0 / 1e3,
        "main thread {main} s/s against ticks of {p50} ms: {text}"
    );
    // Every timed tick in ticks.csv, its ms adding up to the report's.
    let csv = std::fs::read_to_string(dir.join("ticks.csv")).unwrap();
    let rows: Vec<Vec<f64>> =
        csv.lines().skip(1).map(|l| l.split(',').map(|x| x.parse().unwrap()).collect()).collect();
    assert_eq!(rows.len(), 60, "{csv}");
    assert!(rows.iter().all(|r| r.len() == 9), "{csv}");
    let slowest = rows.iter().map(|r| r[1]).fold(0.0, f64::max);
    assert!((slowest - max).abs() < 1e-3, "ticks.csv max {slowest} vs bench.json {max}");
    let parts = |r: &Vec<f64>| r[3..].iter().sum::<f64>();
    assert!(rows.iter().all(|r| (parts(r) - r[1]).abs() < 1e-3), "domains + rest = tick: {csv}");
    // The soak report at a quality level: one row per simulated second.
    let o = volcano()
        .args([
            "bench",
            "--scene",
            "eruption",
            "--quality",
            "low",
            "--seconds",
            "2",
            "--report-every",
            "1",
            "--out",
        ])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(o.status.success(), "soak failed: {}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(dir.join("soak.csv")).unwrap();
    let rows: Vec<&str> = csv.lines().skip(1).collect();
    assert_eq!(rows.len(), 2, "{csv}");
    let cols: Vec<f64> = rows[1].split(',').map(|c| c.parse().unwrap()).collect();
    assert_eq!(cols[0], 2.0, "simulated seconds: {csv}");
    assert!(cols[2] > 100.0 && cols[3] > 1.0 && cols[4] > 0.0, "entities, MiB, p50: {csv}");
    // The interval's CPU: the process's at least the main thread's, which ran the ticks.
    let (cpu, main) = (cols[15], cols[16]);
    assert!(main > 0.0 && cpu >= main, "CPU s/s {cpu}, main thread {main}: {csv}");
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("bench.json")).unwrap()).unwrap();
    assert_eq!((v["ticks"].as_u64(), v["quality"].as_str()), (Some(100), Some("Low")));
    let bad = volcano().args(["bench", "--scene", "atlantis", "--out"]).arg(&dir).output().unwrap();
    assert_eq!(bad.status.code(), Some(2));
    let _ = std::fs::remove_dir_all(&dir);
}

/// `volcano export` writes whole frames (the `.vdb`, its `.json`, the expectation) and refuses
/// bad input with a message naming it, leaving no file behind.
#[test]
fn export_writes_frames_and_refuses_bad_input() {
    let dir = std::env::temp_dir().join(format!("volcano-export-test-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let o = volcano()
        .args(["export", "--scene", "plinian_plume", "--ticks", "50", "--frames", "2", "--every", "25"])
        .args(["--ash-voxel", "40", "--expect", "--camera", "0,2000,0,90,10,8000", "--sun", "90,30", "--out"])
        .arg(&dir)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "export failed: {stderr}");
    assert_eq!(
        stderr.lines().filter(|l| l.starts_with("frame ")).count(),
        2,
        "a progress line per frame: {stderr}"
    );
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    let mut want: Vec<String> = (0..2)
        .flat_map(|f| ["expect.json", "json", "vdb"].map(|ext| format!("frame_{f:04}.{ext}")))
        .collect();
    want.push("terrain.glb".into());
    assert_eq!(names, want);
    let info: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("frame_0001.json")).unwrap()).unwrap();
    assert_eq!(info["tick"], 75);
    // The camera asked for: 8 km east of a focus 2 km up (yaw 90°), 10° above it; the sun due
    // east, 30° up.
    let eye: Vec<f64> = (0..3).map(|a| info["view"]["camera"]["position"][a].as_f64().unwrap()).collect();
    let want = [8000.0 * 10f64.to_radians().cos(), 2000.0 + 8000.0 * 10f64.to_radians().sin(), 0.0];
    assert!(eye.iter().zip(want).all(|(a, b)| (a - b).abs() < 1.0), "camera at {eye:?}, want {want:?}");
    let sun = info["view"]["sun"]["direction"][0].as_f64().unwrap();
    assert!((sun - 30f64.to_radians().cos()).abs() < 1e-4, "sun {sun}");

    let bad: [(&[&str], &str); 5] = [
        (&["--scene", "atlantis", "--ticks", "1"], "unknown scene"),
        (&["--ticks", "1", "--frames", "0"], "--frames"),
        (&["--ticks", "1", "--frames", "3", "--every", "0"], "--every"),
        (&["--ticks", "1", "--ash-voxel", "-5"], "ash_voxel_m"),
        (&["--ticks", "99999999999"], "--ticks"),
    ];
    for (args, message) in bad {
        let out = dir.join("bad");
        let o = volcano().arg("export").args(args).arg("--out").arg(&out).output().unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(message), "{args:?}: {stderr}");
        assert!(!out.exists(), "{args:?} created the folder");
    }
    let o = volcano().args(["export", "--ticks", "1", "--out", "/proc/volcano-export"]).output().unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("/proc/volcano-export"));
    let _ = std::fs::remove_dir_all(dir);
}

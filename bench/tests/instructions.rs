//! `--instructions`: the bench counts each method's instructions per frame by running itself
//! under callgrind (valgrind must be installed: `bash .ci/test` installs it).

use std::process::Command;

#[test]
fn instructions_per_frame_are_counted_for_each_method() {
    let out = std::env::temp_dir().join(format!("lumen-bench-instr-{}", std::process::id()));
    let args = "--quick --scene generated --methods sections,default --x 4 --spokes 32 --frames 20 --warmup 2 --eval-every 100 --eval-escapes-every 0 --no-doubled --no-progress --instructions --out";
    let run = Command::new(env!("CARGO_BIN_EXE_lumen-bench")).args(args.split(' ')).arg(&out).output().expect("lumen-bench runs");
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let count = |method: &str| {
        let run = report["runs"].as_array().unwrap().iter().find(|r| r["method"] == method).unwrap_or_else(|| panic!("no {method} run"));
        run["instructions_per_frame"].as_f64().unwrap_or_else(|| panic!("{method}: no count in {run}"))
    };
    let (sections, default) = (count("sections"), count("default"));
    // A frame of 160 scope samples (x = 4: 637) in a 1,250-ring colon: thousands of
    // instructions a sample, not the whole process (setup is not collected) and not nothing.
    assert!((2e5..2e7).contains(&sections), "sections: {sections} instructions a frame");
    // The default descends to the continuous wall wherever `sections` reads only a section.
    assert!(default > 1.5 * sections, "default {default} against sections {sections}");
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("instructions / frame") && md.contains(&format!("{:.3} M", sections / 1e6)), "{md}");
    let _ = std::fs::remove_dir_all(&out);
}

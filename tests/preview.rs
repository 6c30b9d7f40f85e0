//! `plan` says what a test will identify on a machine before anything is
//! cut or probed, and the uncertainties it predicts are the ones `analyze`
//! then reports.

use fivecal::analyze::ContributorChoice;
use fivecal::analyze::preview;
use fivecal::analyze::usefulness::Usefulness;
use fivecal::identify::Setup;

use crate::analyze_sim::{identify, measure};

use crate::cli::fivecal;

/// What `plan` predicts of the noise's part of u alone (the contributors
/// `--contributors noise` names), with `method` (the test's default when
/// `None`).
fn noise_only_prediction(
    plan: &fivecal::procedure::Plan,
    method: Option<fivecal::identify::Method>,
) -> preview::Preview {
    preview::predict_with(
        plan,
        method,
        None,
        &Usefulness::default(),
        &ContributorChoice::NoiseOnly,
    )
    .unwrap()
}

/// The prediction of the noise's part of u against an analysis of a
/// simulated run of the same plan (location errors of a few tens of
/// micrometres, 0.35 um noise): the same symbols identified, each
/// noise-only u within 20 % (the covariance's u is scaled by the
/// residual sigma, which over 100 to 250 points is within about 10 % of
/// the noise; the covariance's u in turn agrees with the spread of
/// simulated runs, `analyze_sim`).
#[test]
fn plan_predicts_the_symbols_and_u_that_analyze_reports() {
    for (machine, test) in [
        ("bc-trunnion", "stepped-square"),
        ("ac-trunnion", "probe-columns"),
        ("head-table", "probe-sphere"),
    ] {
        let plan = crate::simulate::planned(machine, test);
        let predicted = noise_only_prediction(&plan, None);
        let kin = fivecal::simulate::plan_kinematics(&plan);
        let truth = crate::simulate::truth(&plan, &crate::goodness::location_truth(&kin));
        let data = measure(&plan, &truth, &Default::default());
        let setup = Setup::new(&kin, &data.poses, &[]).unwrap();
        let est = identify(&plan, &setup, &data, predicted.method);
        let mut compared = 0;
        for row in &predicted.rows {
            let (_, u) = est.get(&row.symbol).unwrap();
            match (row.u, u) {
                (Some(p), Some(r)) => {
                    assert!(
                        (p / r - 1.0).abs() < 0.2,
                        "{test} on {machine}: {} predicted u {p:.3}, analyze reports {r:.3}",
                        row.symbol
                    );
                    compared += 1;
                }
                (None, None) => {}
                (p, r) => panic!(
                    "{test} on {machine}: {} predicted {p:?}, analyze reports {r:?}",
                    row.symbol
                ),
            }
        }
        assert!(compared >= 2, "{test} on {machine}: {}", predicted.render());
    }
}

/// `--require all` on a design that leaves errors unseen stops before
/// anything is written and names them; a complete design is planned, and
/// its setup sheet carries the table.
#[test]
fn require_all_refuses_an_incomplete_design_and_the_sheet_shows_the_table() {
    let dir = crate::util::tempdir();
    let refused = dir.path().join("refused");
    let out = fivecal()
        .args([
            "plan",
            "probe-sphere",
            "--machine",
            "head-head",
            "--require",
            "all",
            "--out",
        ])
        .arg(&refused)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(
        err.contains("--require all")
            && err.contains("does not identify")
            && err.contains("EB(0A)S"),
        "{err}"
    );
    assert!(!refused.exists());

    let ok = dir.path().join("ss");
    let out = fivecal()
        .args([
            "plan",
            "stepped-square",
            "--machine",
            "bc-trunnion",
            "--require",
            "all",
            "--out",
        ])
        .arg(&ok)
        .output()
        .unwrap();
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("identifies 8 of 8 location errors"), "{text}");
    let sheet = std::fs::read_to_string(ok.join("stepped-square.md")).unwrap();
    let section = &sheet[sheet.find("## What this test identifies").unwrap()..];
    for s in [
        "EX0B", "EZ0B", "EA0B", "EC0B", "EB0B", "EX(0B)C", "EY0C", "EA(0B)C",
    ] {
        assert!(
            section.contains(&format!("  {s:<10} u =")),
            "{s}\n{section}"
        );
    }
    // The manifest carries the same table: every symbol with the u the
    // screen printed, read back through the manifest reader.
    let manifest =
        fivecal::formats::manifest::Manifest::read(&ok.join("stepped-square.plan.yaml")).unwrap();
    let id = manifest
        .identifies
        .expect("the manifest says what the test identifies");
    assert_eq!(
        (id.method.as_str(), id.rank, id.parameters),
        ("global", 14, 14)
    );
    assert_eq!(id.symbols.len(), 8);
    for (symbol, row) in &id.symbols {
        let u = row.u.unwrap_or_else(|| panic!("{symbol}: {row:?}"));
        let printed = text
            .lines()
            .find(|l| l.trim_start().starts_with(&format!("{symbol} ")))
            .unwrap_or_else(|| panic!("{symbol} not printed:\n{text}"));
        assert!(printed.contains(&format!("{u:.3}")), "{printed} vs {u}");
    }
}

/// The predicted u against the spread of the identified values over 200
/// simulated runs of the same piece or probing (each run its own noise,
/// placement and setups, the errors fixed): the standard deviation of 200
/// draws is within about 5 % of the true one (1/sqrt(2 x 200)), so 20 %
/// is four of its standard errors.
#[test]
fn predicted_u_matches_the_spread_of_200_simulated_runs() {
    use rayon::prelude::*;
    for (machine, test) in [
        ("bc-trunnion", "stepped-square"),
        ("head-table", "probe-columns"),
    ] {
        let plan = crate::simulate::planned(machine, test);
        let predicted = noise_only_prediction(&plan, None);
        let kin = fivecal::simulate::plan_kinematics(&plan);
        let truth = crate::simulate::truth(&plan, &crate::goodness::location_truth(&kin));
        let runs: Vec<Vec<(String, f64)>> = (0..200u64)
            .into_par_iter()
            .map(|seed| {
                let opts = fivecal::simulate::SimOptions {
                    seed: 1000 + seed,
                    ..Default::default()
                };
                let data = measure(&plan, &truth, &opts);
                let setup = Setup::new(&kin, &data.poses, &[]).unwrap();
                let est = identify(&plan, &setup, &data, predicted.method);
                predicted
                    .rows
                    .iter()
                    .filter(|r| r.u.is_some())
                    .map(|r| (r.symbol.clone(), est.get(&r.symbol).unwrap().0))
                    .collect()
            })
            .collect();
        let mut compared = 0;
        for (i, row) in predicted.rows.iter().filter(|r| r.u.is_some()).enumerate() {
            let v: Vec<f64> = runs.iter().map(|r| r[i].1).collect();
            let mean = v.iter().sum::<f64>() / v.len() as f64;
            let sd =
                (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt();
            let u = row.u.unwrap();
            assert!(
                (u / sd - 1.0).abs() < 0.2,
                "{test} on {machine}: {} predicted u {u:.4}, spread of 200 runs {sd:.4}",
                row.symbol
            );
            compared += 1;
        }
        assert!(compared >= 4, "{test} on {machine}");
    }
}

/// A user's template with fewer poses than the test needs: the built-in
/// one with `from` replaced by `to`.
fn thinned(test: &str, from: &str, to: &str) -> String {
    let text = fivecal::procedure::Test::ALL
        .into_iter()
        .find(|t| t.as_str() == test)
        .unwrap()
        .template_text();
    assert!(text.contains(from), "{test}: {from}");
    text.replacen(from, to, 1)
}

/// Sets the keys of `fragment` in `doc` as a user edits a template: a
/// mapping goes key by key, anything else replaces the value.
fn merge(doc: &mut serde_yaml::Value, fragment: &serde_yaml::Value) {
    match (doc.as_mapping_mut(), fragment.as_mapping()) {
        (Some(d), Some(f)) => {
            for (k, v) in f {
                match d.get_mut(k) {
                    Some(old) if old.is_mapping() && v.is_mapping() => merge(old, v),
                    _ => {
                        d.insert(k.clone(), v.clone());
                    }
                }
            }
        }
        _ => *doc = fragment.clone(),
    }
}

/// Plans `template` on `machine` with the command line `args`, and reads
/// back the manifest and what was printed.
fn plan_with(
    args: &[String],
    out: &std::path::Path,
) -> (fivecal::formats::manifest::Manifest, String) {
    let run = fivecal().args(args).arg("--out").arg(out).output().unwrap();
    let text = String::from_utf8(run.stdout).unwrap();
    assert!(
        run.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&run.stderr)
    );
    let test = &args[1];
    let manifest =
        fivecal::formats::manifest::Manifest::read(&out.join(format!("{test}.plan.yaml"))).unwrap();
    (manifest, text)
}

/// Where a design leaves location errors unidentified, `plan` names the
/// known changes of the template that identify them. Each change, made in
/// the template as the manifest states it and planned with the command it
/// gives, identifies the errors it claimed with the u it claimed; and on
/// the simulator, `analyze` then reports them with that u (within 20 %, as
/// above; not for the sphere grid, whose sphere fits leave one residual
/// degree of freedom per pose, about 20 in all, so that the reported u,
/// scaled by the residual sigma, scatters by some 16 % itself).
#[test]
fn a_suggested_change_identifies_what_it_claims() {
    let dir = crate::util::tempdir();
    for (test, machine, from, to) in [
        // One tilt angle: the B axis's location is not seen.
        ("stepped-square", "bc-trunnion", "tilt: auto ", "tilt: [0] "),
        // One C angle: the C axis's location is not seen.
        (
            "probe-columns",
            "ac-trunnion",
            "c: [0, 60, 120, 180, 240, 300]",
            "c: [0]",
        ),
        // A grid at one tilt: the sphere method has no arc about B.
        (
            "probe-sphere",
            "bc-trunnion",
            "pattern: seed-004",
            "pattern: grid",
        ),
    ] {
        let text = if test == "probe-sphere" {
            thinned(test, from, to).replace("tilt: [-90, -45, 0]", "tilt: [0]")
        } else {
            thinned(test, from, to)
        };
        let case = dir.path().join(format!("{test}-{machine}"));
        std::fs::create_dir_all(&case).unwrap();
        let template = case.join("mine.yaml");
        std::fs::write(&template, &text).unwrap();
        let args: Vec<String> = [
            "plan",
            test,
            "--machine",
            machine,
            "--template",
            template.to_str().unwrap(),
        ]
        .map(String::from)
        .to_vec();
        let (first, printed) = plan_with(&args, &case.join("first"));
        let missing: Vec<&String> = first
            .identifies
            .as_ref()
            .unwrap()
            .symbols
            .iter()
            .filter(|(_, s)| s.u.is_none())
            .map(|(n, _)| n)
            .collect();
        assert!(!missing.is_empty(), "{test} on {machine}: {printed}");
        assert!(
            !first.suggestions.is_empty() && printed.contains("changes that identify more"),
            "{test} on {machine}: {printed}"
        );
        for (i, s) in first.suggestions.iter().enumerate() {
            // A second run is another machine file, not a template edit
            // (`a_second_run_with_another_probe_frees_the_head_alias`).
            if s.second_run.is_some() {
                continue;
            }
            // Only errors the plan left unidentified are claimed.
            assert!(
                s.identifies.keys().all(|k| missing.contains(&k)),
                "{test} on {machine}: {s:?}"
            );
            // The user's edit: the fragment's keys set in their template.
            let mut doc: serde_yaml::Value = serde_yaml::from_str(&text).unwrap();
            merge(&mut doc, &s.set);
            let changed = case.join(format!("changed{i}.yaml"));
            std::fs::write(&changed, serde_yaml::to_string(&doc).unwrap()).unwrap();
            // The command the suggestion gives, on the changed file.
            let command = s.command.as_deref().unwrap();
            let mut words: Vec<String> = command
                .split_whitespace()
                .skip(1)
                .map(String::from)
                .collect();
            assert_eq!(
                words[..2],
                ["plan".to_string(), test.to_string()],
                "{command}"
            );
            let at = words.iter().position(|w| w == "--template").unwrap() + 1;
            assert_eq!(words[at], template.to_str().unwrap(), "{command}");
            words[at] = changed.to_str().unwrap().to_string();
            // Issue 46 item 8: the command kept its --out, into a directory
            // of its own (this plan's holds the template it reads).
            let o = words.iter().position(|w| w == "--out").expect(command);
            assert!(
                words[o + 1] == "revised" || words[o + 1].ends_with("-revised"),
                "{command}"
            );
            words.drain(o..o + 2);
            let (second, _) = plan_with(&words, &case.join(format!("second{i}")));
            let id = second.identifies.unwrap();
            let seen = id.symbols.values().filter(|r| r.u.is_some()).count();
            assert_eq!(seen, s.identified, "{test} on {machine}: {}", s.change);
            assert_eq!(
                second.poses.len(),
                s.poses,
                "{test} on {machine}: {}",
                s.change
            );
            for (symbol, claim) in &s.identifies {
                let got = id.symbols[symbol].u.unwrap_or_else(|| {
                    panic!("{test} on {machine}, {}: {symbol} not identified", s.change)
                });
                let u = claim.u.unwrap();
                assert!(
                    (got / u - 1.0).abs() < 1e-9,
                    "{test} on {machine}, {}: {symbol} u {got} against the claimed {u}",
                    s.change
                );
            }
            // And on the simulator, analyze reports them with that u.
            if i == 0 && test != "probe-sphere" {
                let machine = fivecal::machine::Machine::resolve(machine).unwrap().0;
                let template = fivecal::procedure::Template::parse(
                    &changed,
                    &std::fs::read_to_string(&changed).unwrap(),
                )
                .unwrap();
                let mut cfg = fivecal::procedure::PlanConfig::builtin(machine, template.test());
                cfg.template = template;
                let plan = fivecal::procedure::plan(&cfg).unwrap();
                let kin = fivecal::simulate::plan_kinematics(&plan);
                let truth = crate::simulate::truth(&plan, &crate::goodness::location_truth(&kin));
                let data = measure(&plan, &truth, &Default::default());
                let setup = Setup::new(&kin, &data.poses, &[]).unwrap();
                let method = id.method.parse().unwrap();
                let est = identify(&plan, &setup, &data, method);
                // The claim is the changed plan's own prediction (the same
                // contributors as `plan` prints), and analyze sees each
                // claimed symbol.
                let own = preview::predict(&plan, Some(method), None).unwrap();
                for (symbol, claim) in &s.identifies {
                    let (_, r) = est.get(symbol).unwrap();
                    r.unwrap_or_else(|| panic!("{test}: analyze does not report {symbol}"));
                    let p = claim.u.unwrap();
                    let r = own
                        .rows
                        .iter()
                        .find(|row| row.symbol == *symbol)
                        .and_then(|row| row.u)
                        .unwrap_or_else(|| panic!("{test}: plan does not predict {symbol}"));
                    assert!(
                        (p / r - 1.0).abs() < 0.2,
                        "{test}: {symbol} claimed u {p:.3}, the changed plan predicts {r:.3}"
                    );
                }
            }
        }
    }
}

/// A design that identifies every location error suggests nothing: no
/// line on screen, no section in the setup sheet, no `suggestions:` in
/// the manifest; one whose gaps no known change closes says so, and
/// `--require all` repeats it.
#[test]
fn a_complete_design_suggests_nothing() {
    let plan = crate::simulate::planned("bc-trunnion", "probe-columns");
    let predicted = preview::predict(&plan, None, None).unwrap();
    assert!(predicted.missing().is_empty());
    let cfg = fivecal::procedure::PlanConfig::builtin(
        plan.machine().clone(),
        fivecal::procedure::Test::ProbeColumns,
    );
    let none = fivecal::discover::suggest::suggest(&cfg, &plan, &predicted, None);
    assert!(none.found.is_empty() && none.tried.is_empty() && !none.wanted);

    let dir = crate::util::tempdir();
    let args = ["plan", "stepped-square", "--machine", "ac-trunnion"].map(String::from);
    let (manifest, printed) = plan_with(&args, &dir.path().join("ss"));
    assert!(manifest.suggestions.is_empty());
    assert!(
        !printed.contains("identify more") && !printed.contains("known change"),
        "{printed}"
    );
    let sheet = std::fs::read_to_string(dir.path().join("ss/stepped-square.md")).unwrap();
    assert!(!sheet.contains("What would identify more"));

    // The B head's offset and angle alias at the one probe length the run
    // has: no change of the template separates them, and plan says so.
    let out = fivecal()
        .args([
            "plan",
            "probe-columns",
            "--machine",
            "head-table",
            "--require",
            "all",
            "--out",
        ])
        .arg(dir.path().join("both"))
        .output()
        .unwrap();
    // Only a second run with another probe length separates them
    // (`a_second_run_with_another_probe_frees_the_head_alias`): with
    // `--require all` plan writes that second run too (issue 41 item 3),
    // beside the first, each with its machine file.
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for d in ["both", "both-second"] {
        assert!(
            dir.path().join(d).join("probe-columns.plan.yaml").exists()
                && dir
                    .path()
                    .join(d)
                    .join("probe-columns.machine.yaml")
                    .exists(),
            "{d}: {text}"
        );
    }
    let second =
        std::fs::read_to_string(dir.path().join("both-second/probe-columns.machine.yaml")).unwrap();
    assert!(second.contains("168"), "{second}");
}

/// Runs `fivecal` with `words` in `dir` and says what it printed.
fn run_in(dir: &std::path::Path, words: &[String]) -> String {
    let run = fivecal().args(words).current_dir(dir).output().unwrap();
    assert!(
        run.status.success(),
        "{words:?}: {}",
        String::from_utf8_lossy(&run.stderr)
    );
    String::from_utf8(run.stdout).unwrap()
}

/// On `head-table` the probe-columns run sees the B head's X offset and
/// its angle only as `0.2850 EX0B - EB0B`: the probe's ball, 180 mm of
/// pivot and 105 mm of probe below the B axis, moves alike for both, and
/// so for EY0C and EA(0B)S. No pose separates them; a second run with
/// another probe length does. `plan` says so, with what the two runs
/// identify together and the u each will have; done as it says (the
/// machine file copied with the probe length set, the second run planned
/// with its command, both runs simulated on a machine with known location
/// errors and fitted together with the `discover` command it gives), each
/// freed error is reported within 4 u of the truth, with a u within 30 %
/// of the claimed one (the reported u is scaled by the residual sigma of
/// about 200 degrees of freedom, within some 10 % of the noise).
#[test]
fn a_second_run_with_another_probe_frees_the_head_alias() {
    let tmp = crate::util::tempdir();
    let dir = tmp.path();
    let words =
        |c: &str| -> Vec<String> { c.split_whitespace().skip(1).map(String::from).collect() };
    let printed = run_in(
        dir,
        &words("fivecal plan probe-columns --machine head-table --out first"),
    );
    assert!(printed.contains("0.2850 EX0B - EB0B"), "{printed}");
    let manifest =
        fivecal::formats::manifest::Manifest::read(&dir.join("first/probe-columns.plan.yaml"))
            .unwrap();
    let s = manifest
        .suggestions
        .iter()
        .find(|s| s.second_run.is_some())
        .unwrap_or_else(|| panic!("no second run suggested: {printed}"));
    let second = s.second_run.as_ref().unwrap();
    for freed in ["EX0B", "EB0B", "EY0C", "EA(0B)S"] {
        assert!(s.identifies.contains_key(freed), "{freed}: {s:?}");
    }
    assert_eq!(s.identified, 10, "{s:?}");
    assert!(
        printed.contains(&s.change)
            && printed.contains("then, both runs measured: fivecal discover"),
        "{printed}"
    );
    let sheet = std::fs::read_to_string(dir.join("first/probe-columns.md")).unwrap();
    assert!(
        sheet.contains(&format!("### {}", s.change)) && sheet.contains(&second.together),
        "{sheet}"
    );

    // The user's copy of the machine file, with the probe length set.
    let mut machine: serde_yaml::Value =
        serde_yaml::from_str(&std::fs::read_to_string(dir.join(&second.copy_of)).unwrap()).unwrap();
    merge(&mut machine, &second.machine_set);
    std::fs::write(
        dir.join(&second.machine_file),
        serde_yaml::to_string(&machine).unwrap(),
    )
    .unwrap();
    let command = s.command.as_deref().unwrap();
    run_in(dir, &words(command));

    // Both runs on a machine with known location errors, each its own
    // seed, and the two fitted together as the suggestion says.
    let plan = crate::simulate::planned("head-table", "probe-columns");
    let kin = fivecal::simulate::plan_kinematics(&plan);
    let truth = format!(
        "machine: head-table\n{}",
        crate::goodness::location_truth(&kin)
    );
    std::fs::write(dir.join("truth.yaml"), &truth).unwrap();
    let out = words(command)
        .iter()
        .skip_while(|w| *w != "--out")
        .nth(1)
        .unwrap()
        .clone();
    for (manifest, file, seed) in [
        ("first", "first.csv", "11"),
        (out.as_str(), "second.csv", "12"),
    ] {
        run_in(
            dir,
            &words(&format!(
                "fivecal simulate --plan {manifest}/probe-columns.plan.yaml --errors truth.yaml --seed {seed} --format csv -o {file}"
            )),
        );
    }
    let together = second
        .together
        .replace("FIRST-RUN-MEASURED", "first.csv")
        .replace("SECOND-RUN-MEASURED", "second.csv")
        + " --no-record --out result.yaml";
    run_in(dir, &words(&together));
    let result: serde_yaml::Value =
        serde_yaml::from_str(&std::fs::read_to_string(dir.join("result.yaml")).unwrap()).unwrap();
    let truth: serde_yaml::Value = serde_yaml::from_str(&truth).unwrap();
    for (symbol, claim) in &s.identifies {
        let got = &result["location_errors"][symbol.as_str()];
        let (value, u) = (got["value"].as_f64().unwrap(), got["u"].as_f64().unwrap());
        let t = truth["location_errors"][symbol.as_str()].as_f64().unwrap();
        let claimed = claim.u.unwrap();
        assert!(
            (value - t).abs() < 4.0 * u,
            "{symbol}: {value} +- {u} against the truth {t}"
        );
        assert!(
            (u / claimed - 1.0).abs() < 0.3,
            "{symbol}: u {u} against the claimed {claimed}"
        );
    }
}

/// The joint design of one run is that run's design: the same fit as
/// `analyze`'s global method, the same u for what it identifies.
#[test]
fn the_joint_design_of_one_run_is_its_own() {
    let plan = crate::simulate::planned("head-table", "probe-columns");
    // The joint design speaks of the noise alone: so does this prediction.
    let predicted = noise_only_prediction(&plan, Some(fivecal::identify::Method::Global));
    let kin = fivecal::simulate::plan_kinematics(&plan);
    let data = preview::nominal_data(&plan).unwrap();
    let (rows, _) =
        fivecal::discover::suggest::joint(&[(&plan, &kin, &data)], predicted.noise.um).unwrap();
    for (a, b) in predicted.rows.iter().zip(&rows) {
        assert_eq!(a.symbol, b.symbol);
        match (a.u, b.u) {
            (Some(x), Some(y)) => assert!((x / y - 1.0).abs() < 1e-6, "{}: {x} {y}", a.symbol),
            (None, None) => {}
            (x, y) => panic!("{}: {x:?} against {y:?}", a.symbol),
        }
    }
}

/// The u `plan` prints and the u `analyze` reports are one model: the
/// test's contributors through the fit's response, at the nominal machine
/// and at the estimate. On every built-in machine, for the stepped square
/// and the columns (the global method), each value `analyze` reports from
/// a simulated run with location errors of tens of micrometres has the u
/// `plan` predicted within 20 %, and each symbol counted the same way.
#[test]
fn plan_and_analyze_report_the_same_full_u_on_every_built_in_machine() {
    let mut all = Vec::new();
    for machine in ["bc-trunnion", "ac-trunnion", "head-table", "head-head"] {
        for test in ["stepped-square", "probe-columns"] {
            // Left out: head-head's stepped square is nearly degenerate at
            // the nominal machine (plan: EA0A u 529 urad, EX0C 58 um),
            // while the fit's response at an estimate with tens of
            // micrometres of error sees those directions (37 urad, 9.8 um).
            // Every real machine sits off the degenerate point: the
            // estimate's u is the one that holds, even for a nearly
            // nominal machine (`montecarlo::the_printed_u_covers_exact_runs_
            // drawn_with_its_contributors`), and plan's is an upper bound.
            if (machine, test) == ("head-head", "stepped-square") {
                continue;
            }
            let plan = crate::simulate::planned(machine, test);
            let predicted = preview::predict(&plan, None, None).unwrap();
            let kin = fivecal::simulate::plan_kinematics(&plan);
            let dir = crate::util::tempdir();
            let manifest = dir.path().join("plan.yaml");
            let measured = dir.path().join("measured.csv");
            let truth = crate::simulate::truth(&plan, &crate::goodness::location_truth(&kin));
            let sim = fivecal::simulate::run(&plan, &truth, &Default::default()).unwrap();
            sim.write(fivecal::simulate::Format::Csv, &measured)
                .unwrap();
            let outcome = fivecal::analyze::run(&fivecal::analyze::Request {
                rebuilt: Some((*plan).clone()),
                ..fivecal::analyze::Request::new(&manifest, vec![measured])
            })
            .unwrap();
            let fivecal::analyze::Found::Identified(id) = outcome.found else {
                panic!("{test} on {machine}: not identified")
            };
            let file = &id.pieces[0].file;
            let explained = file.uncertainty.as_ref().unwrap();
            assert!(
                explained.basis.contains("closed form"),
                "{}",
                explained.basis
            );
            let mut compared = 0;
            let mut off = Vec::new();
            for row in &predicted.rows {
                let reported = file.location_errors.get(&row.symbol).and_then(|q| q.u);
                match (row.u, reported) {
                    (Some(p), Some(r)) => {
                        if (p / r - 1.0).abs() >= 0.2 {
                            off.push(format!("{}: plan u {p:.3}, analyze u {r:.3}", row.symbol));
                        }
                        compared += 1;
                    }
                    (None, None) => {}
                    (p, r) => off.push(format!(
                        "{}: plan {p:?} ({:?}), analyze {r:?}",
                        row.symbol, row.reason
                    )),
                }
            }
            all.extend(off.into_iter().map(|o| format!("{test} on {machine}: {o}")));
            assert!(compared >= 2, "{test} on {machine}: {}", predicted.render());
        }
    }
    assert!(all.is_empty(), "{all:#?}");
}

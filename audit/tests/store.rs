//! The audit database on registrations simulated with a seed: one row per registration ×
//! combination (an unreadable file included), resume, two runs at once, the schema version,
//! the per-valve read model, and the shared plant data (skipped when absent).

#![allow(clippy::unwrap_used)]

use std::path::{Path, PathBuf};

use audit::{AuditError, Store, SCHEMA_VERSION};
use datasets::simulate::Scenario;
use monitoring::batch::BatchOptions;
use run::SearchArgs;
use stiction_models::Kano;

/// A fresh temporary directory.
fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("stiction-audit-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A simulated registration of `name` (S = `s`, J = 1, 400 samples).
fn write_loop(dir: &Path, name: &str, s: f64, seed: u64) -> PathBuf {
    let scenario = Scenario {
        valve: Box::new(Kano::params().s(s).j(1.0).check().unwrap()),
        samples: 400,
        seed,
        ..Scenario::default()
    };
    let path = dir.join(name);
    let f = std::fs::File::create(&path).unwrap();
    scenario.simulate().unwrap().write_csv(f).unwrap();
    path
}

/// A file the reader refuses (a cell that is not a number).
fn write_broken(dir: &Path, name: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, "t,SP,PV,OP\n0,1,2,x\n").unwrap();
    path
}

/// kano and he × arx on a coarse exhaustive grid: fast.
fn options() -> BatchOptions {
    let search = SearchArgs {
        step: Some(1.0),
        ..SearchArgs::default()
    };
    BatchOptions {
        stiction: vec!["kano".into(), "he".into()],
        settings: search.settings(&["arx"]).unwrap(),
        ..BatchOptions::default()
    }
}

fn files(dir: &Path) -> Vec<PathBuf> {
    let (files, _) = monitoring::registration::expand(&[dir.to_path_buf()], &[], "OP").unwrap();
    files
}

fn sqlite(db: &Path) -> rusqlite::Connection {
    rusqlite::Connection::open(db).unwrap()
}

#[test]
fn every_registration_has_a_row_per_combination_and_a_second_run_adds_nothing() {
    let dir = temp_dir("resume");
    write_loop(&dir, "V1_20240101-0800.csv", 2.0, 1);
    write_loop(&dir, "V1_20240201-0800.csv", 4.0, 2);
    write_broken(&dir, "V1_20240301-0800.csv");
    let db = dir.join("audit.sqlite");
    let mut given = files(&dir);
    assert_eq!(given.len(), 3);
    // The same file twice (and once more through another spelling of its path) counts once.
    given.push(given[0].clone());
    given.push(dir.join(".").join("V1_20240101-0800.csv"));
    let opts = options();

    let first = audit::run(&given, &opts, None, &db, None).unwrap();
    assert_eq!(first.files, 3);
    assert_eq!(first.duplicates, 2);
    assert_eq!(first.computed, 3);
    assert_eq!(first.skipped, 0);
    assert_eq!(first.rows_inserted, 3 * 2);
    assert_eq!(first.total_rows, 3 * 2);

    // The unreadable file: one error row per combination, with its one-line error.
    let conn = sqlite(&db);
    let errors: Vec<(String, String, String)> = conn
        .prepare("SELECT stiction_model, linear_model, error FROM results WHERE status = 'error' ORDER BY stiction_model")
        .unwrap()
        .query_map([], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)))
        .unwrap()
        .map(Result::unwrap)
        .collect();
    assert_eq!(errors.len(), 2, "{errors:?}");
    assert_eq!((errors[0].0.as_str(), errors[0].1.as_str()), ("he", "arx"));
    assert_eq!(
        (errors[1].0.as_str(), errors[1].1.as_str()),
        ("kano", "arx")
    );
    assert!(!errors[0].2.is_empty());
    // An ok row carries its quantify record and its repair (or why there is none).
    let (quantify, repair, reason): (String, Option<String>, Option<String>) = conn
        .query_row(
            "SELECT quantify, repair, repair_reason FROM results WHERE status = 'ok' LIMIT 1",
            [],
            |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)),
        )
        .unwrap();
    let q: serde_json::Value = serde_json::from_str(&quantify).unwrap();
    assert!(q["S"].is_number(), "{q}");
    assert!(repair.is_some() != reason.is_some());
    let start: String = conn
        .query_row(
            "SELECT start_time FROM results WHERE file = 'V1_20240201-0800.csv' LIMIT 1",
            [],
            |r| r.get(0),
        )
        .unwrap();
    assert_eq!(start, "2024-02-01 08:00");

    let second = audit::run(&given, &opts, None, &db, None).unwrap();
    assert_eq!(second.computed, 0);
    assert_eq!(second.skipped, 3);
    assert_eq!(second.rows_inserted, 0);
    assert_eq!(second.total_rows, 3 * 2);

    // Other settings are other rows; the file's content, not its name, is the registration.
    let one = BatchOptions {
        stiction: vec!["kano".into()],
        ..opts.clone()
    };
    let third = audit::run(&given[..1], &one, None, &db, None).unwrap();
    assert_eq!(
        (third.computed, third.rows_inserted, third.total_rows),
        (1, 1, 7)
    );
    let copy = dir.join("copy");
    std::fs::create_dir_all(&copy).unwrap();
    std::fs::copy(&given[0], copy.join("V1_20240101-0800.csv")).unwrap();
    let fourth = audit::run(&files(&copy), &one, None, &db, None).unwrap();
    assert_eq!(
        (fourth.computed, fourth.skipped, fourth.total_rows),
        (0, 1, 7)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn two_runs_at_once_add_each_row_once() {
    let dir = temp_dir("concurrent");
    for k in 0..4 {
        write_loop(
            &dir,
            &format!("V2_2024010{}-0800.csv", k + 1),
            1.0 + k as f64,
            10 + k,
        );
    }
    write_broken(&dir, "V2_20240301-0800.csv");
    let db = dir.join("audit.sqlite");
    let given = files(&dir);
    let opts = options();
    let runs: Vec<audit::AuditRun> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..2)
            .map(|_| scope.spawn(|| audit::run(&given, &opts, None, &db, None).unwrap()))
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    let expected = 5 * 2;
    assert_eq!(runs[0].rows_inserted + runs[1].rows_inserted, expected);
    let conn = sqlite(&db);
    let (n, distinct): (i64, i64) = conn
        .query_row(
            "SELECT count(*), count(DISTINCT content_hash || '|' || stiction_model || '|' || linear_model) FROM results",
            [],
            |r| Ok((r.get(0)?, r.get(1)?)),
        )
        .unwrap();
    assert_eq!((n, distinct), (expected as i64, expected as i64));
    let mode: String = conn
        .query_row("PRAGMA journal_mode", [], |r| r.get(0))
        .unwrap();
    assert_eq!(mode, "wal");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_schema_version_is_set_and_a_newer_or_foreign_database_is_refused() {
    let dir = temp_dir("schema");
    let db = dir.join("audit.sqlite");
    let store = Store::open(&db).unwrap();
    assert_eq!(store.count().unwrap(), 0);
    drop(store);
    let conn = sqlite(&db);
    let version: i64 = conn
        .query_row("PRAGMA user_version", [], |r| r.get(0))
        .unwrap();
    assert_eq!(version, SCHEMA_VERSION);
    assert_eq!(SCHEMA_VERSION, 2);
    let app: i64 = conn
        .query_row("PRAGMA application_id", [], |r| r.get(0))
        .unwrap();
    assert_eq!(app, audit::APPLICATION_ID);
    // Opening again changes nothing.
    Store::open(&db).unwrap();

    conn.pragma_update(None, "user_version", 7).unwrap();
    drop(conn);
    let e = Store::open(&db).unwrap_err();
    assert!(
        matches!(
            e,
            AuditError::NewerSchema {
                found: 7,
                known: 2,
                ..
            }
        ),
        "{e:?}"
    );
    let line = run::error_line(&e);
    assert!(!line.contains('\n'));
    assert_eq!(
        line,
        format!(
            "{}: audit database schema version 7 is newer than this program's (2): use a newer stiction",
            db.display()
        )
    );

    // Another application's SQLite file is left alone; a text file is not a database.
    let other = dir.join("other.sqlite");
    let c = sqlite(&other);
    c.execute_batch("CREATE TABLE t (x INTEGER);").unwrap();
    drop(c);
    let e = Store::open(&other).unwrap_err();
    assert!(
        run::error_line(&e).contains("not a stiction audit database"),
        "{e}"
    );
    let mode: String = sqlite(&other)
        .query_row("PRAGMA journal_mode", [], |r| r.get(0))
        .unwrap();
    assert_eq!(mode, "delete", "the foreign file was changed");
    let text = dir.join("rows.csv");
    std::fs::write(
        &text,
        "this is not a database, just some text that is long enough\n".repeat(20),
    )
    .unwrap();
    let e = Store::open(&text).unwrap_err();
    assert!(
        run::error_line(&e).ends_with("not a stiction audit database (not an SQLite file)"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn valves_orders_each_valves_registrations_by_start_time() {
    let dir = temp_dir("valves");
    // Written (and so listed, by name) out of time order for V3: the names sort by valve and
    // time, so a third valve's files interleave nothing; the order must come from start_time.
    write_loop(&dir, "V3_20240301-0800.csv", 3.0, 21);
    write_loop(&dir, "V3_20240101-0800.csv", 1.0, 22);
    write_loop(&dir, "V3_20240201-0800.csv", 2.0, 23);
    write_loop(&dir, "A1_20240105-0000.csv", 2.0, 24);
    let db = dir.join("audit.sqlite");
    let mut given = files(&dir);
    given.reverse();
    let run = audit::run(&given, &options(), None, &db, None).unwrap();
    assert_eq!(run.total_rows, 4 * 2);
    let valves = Store::open(&db).unwrap().valves().unwrap();
    let names: Vec<&str> = valves.iter().map(|v| v.valve.as_str()).collect();
    assert_eq!(names, ["A1", "V3"]);
    let times: Vec<&str> = valves[1]
        .registrations
        .iter()
        .map(|r| r.start_time.as_str())
        .collect();
    assert_eq!(
        times,
        ["2024-01-01 08:00", "2024-02-01 08:00", "2024-03-01 08:00"]
    );
    for r in valves.iter().flat_map(|v| &v.registrations) {
        assert_eq!(r.combinations, 2);
        assert!(r.ok, "{r:?}");
        assert!(r.s.is_some() && r.s_range.is_some());
        assert!(!r.detect_verdict.is_empty());
        assert!(r.file.ends_with(".csv") && r.path.ends_with(&r.file));
        assert_eq!(r.content_hash.len(), 64);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_plant_data_gives_one_row_per_registration() {
    let plant = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/plant");
    if !plant.is_dir() {
        println!("skipped: no plant data at {}", plant.display());
        return;
    }
    let dir = temp_dir("plant");
    let db = dir.join("audit.sqlite");
    let given = files(&plant);
    let run = audit::run(&given, &BatchOptions::default(), None, &db, None).unwrap();
    assert_eq!(run.files, given.len());
    assert_eq!(run.total_rows, given.len());
    assert_eq!(Store::open(&db).unwrap().count().unwrap(), given.len());
    let _ = std::fs::remove_dir_all(&dir);
}

/// A loop of the simulated population `wide(4242)` (never the plant data) written as a
/// historian record: time, SP, PV and OP as logged, no MV.
fn write_population_loop(
    dir: &Path,
    name: &str,
    l: &datasets::simulate::population::PopulationLoop,
) {
    let sim = &l.sim;
    let mut text = String::from("t,SP,PV,OP\n");
    for k in 0..sim.pv.len() {
        text.push_str(&format!(
            "{},{},{},{}\n",
            sim.t[k], sim.sp[k], sim.pv[k], sim.op[k]
        ));
    }
    std::fs::write(dir.join(name), text).unwrap();
}

/// Whether `s` (% of valve span) agrees with the detector's `verdict`: a sticky valve more
/// than the negligible band, a free one less than the maintenance threshold.
fn agrees(verdict: &str, s: f64) -> bool {
    match verdict {
        "stiction" => s > grid_search::NEGLIGIBLE_S,
        "no-stiction" => s < grid_search::MAINTENANCE_S,
        _ => true,
    }
}

/// The database holds each registration's one answer: where the combination's one-step S
/// contradicts the detector's verdict (a `stiction` verdict with S <= 0.2 %, `no-stiction`
/// with S >= 1.6 %), `S` is the detector's output-error S that agrees with it, and the
/// one-step S stays beside it (`S_one_step`); elsewhere `S` is the one-step S. The loops are
/// the short ones (at most 600 samples) of the first 90 of a simulated population; at least
/// one of them must have a contradicting one-step S, or the test exercises nothing.
#[test]
fn the_rows_carry_the_s_that_explains_the_verdict() {
    let dir = temp_dir("answer");
    let spec = datasets::simulate::population::PopulationSpec::wide(4242);
    let mut n = 0;
    for i in 0..90 {
        let l = spec.generate(i).unwrap();
        if l.sim.pv.len() <= 600 {
            write_population_loop(&dir, &format!("P{i}_20240101-0800.csv"), &l);
            n += 1;
        }
    }
    assert!(n >= 10, "{n} short loops");
    let db = dir.join("audit.sqlite");
    let opts = BatchOptions::default();
    audit::run(&files(&dir), &opts, None, &db, None).unwrap();
    let conn = sqlite(&db);
    type Cells = (String, String, f64, f64, f64, String, f64, f64, f64, String);
    let rows: Vec<Cells> = conn
        .prepare(
            "SELECT file, detect_verdict, S, S_lo, S_hi, S_from, S_one_step, S_one_step_lo,
                    S_one_step_hi, S_unit FROM results WHERE status = 'ok'",
        )
        .unwrap()
        .query_map([], |r| {
            Ok((
                r.get(0)?,
                r.get(1)?,
                r.get(2)?,
                r.get(3)?,
                r.get(4)?,
                r.get(5)?,
                r.get(6)?,
                r.get(7)?,
                r.get(8)?,
                r.get(9)?,
            ))
        })
        .unwrap()
        .map(Result::unwrap)
        .collect();
    assert!(!rows.is_empty(), "no ok row of {n} loops");
    let mut contradicted = 0;
    for (file, verdict, s, lo, hi, from, one, one_lo, one_hi, unit) in &rows {
        assert_eq!(unit, "% of valve span", "{file}");
        assert!(lo <= s && s <= hi, "{file}: {s} [{lo}, {hi}]");
        assert!(
            *lo <= *one_lo && *one_hi <= *hi,
            "{file}: the range holds the one-step region"
        );
        if agrees(verdict, *one) {
            assert_eq!((from.as_str(), s), ("one-step", one), "{file}");
        } else {
            contradicted += 1;
            assert_eq!(from, "output-error", "{file}: {verdict}, one-step S {one}");
            assert!(agrees(verdict, *s), "{file}: {verdict} with S {s}");
        }
    }
    assert!(
        contradicted >= 1,
        "no loop's one-step S contradicts its verdict: the test exercises nothing"
    );
    // A repair simulated with a valve that contradicts the verdict is not this valve's: no
    // benefit is stored for it, and the reason says so.
    for (file, verdict, .., one, _, _, _) in &rows {
        let (reduction, reason): (Option<f64>, Option<String>) = conn
            .query_row(
                "SELECT reduction, repair_reason FROM results WHERE file = ?1 AND status = 'ok'",
                [file],
                |r| Ok((r.get(0)?, r.get(1)?)),
            )
            .unwrap();
        if !agrees(verdict, *one) {
            assert_eq!(reduction, None, "{file}: {verdict} with one-step S {one}");
            assert!(
                reason.as_deref().is_some_and(|r| r.contains("contradicts")),
                "{file}: {reason:?}"
            );
        }
    }
    // The fleet's read model shows the same S.
    let valves = Store::open(&db).unwrap().valves().unwrap();
    for v in &valves {
        for r in v.registrations.iter().filter(|r| r.ok) {
            let row = rows.iter().find(|x| x.0 == r.file).unwrap();
            assert_eq!(r.s, Some(row.2), "{}", r.file);
            assert_eq!(r.s_from.as_deref(), Some(row.5.as_str()));
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A database of schema version 1 (written before the registration's one answer) opens: it is
/// migrated in place, its rows kept and marked as holding the one-step S.
#[test]
fn a_version_1_database_is_migrated_and_its_rows_kept() {
    let dir = temp_dir("v1");
    let db = dir.join("audit.sqlite");
    let conn = sqlite(&db);
    conn.execute_batch(audit::MIGRATIONS[0]).unwrap();
    conn.pragma_update(None, "user_version", 1).unwrap();
    conn.pragma_update(None, "application_id", audit::APPLICATION_ID)
        .unwrap();
    conn.execute(
        "INSERT INTO results (content_hash, valve, start_time, file, path, settings,
            stiction_model, linear_model, status, S, S_lo, S_hi, integrating, detect_verdict,
            why, notes, audited_at)
         VALUES ('h', 'V9', '2024-01-01 08:00', 'V9_20240101-0800.csv', 'x', '{}', 'kano',
            'arx', 'ok', 0.1, 0.04, 0.1, 0, 'stiction', '[]', '[]', '2026-11-01T00:00:00Z')",
        [],
    )
    .unwrap();
    drop(conn);
    let store = Store::open(&db).unwrap();
    assert_eq!(store.count().unwrap(), 1);
    let valves = store.valves().unwrap();
    let r = &valves[0].registrations[0];
    assert_eq!((r.s, r.s_from.as_deref()), (Some(0.1), Some("one-step")));
    assert_eq!(
        (r.s_unit.as_deref(), r.detect_reason.as_deref()),
        (None, None)
    );
    drop(store);
    let (version, one_step): (i64, f64) = sqlite(&db)
        .query_row(
            "SELECT (SELECT user_version FROM pragma_user_version), S_one_step FROM results",
            [],
            |r| Ok((r.get(0)?, r.get(1)?)),
        )
        .unwrap();
    assert_eq!((version, one_step), (SCHEMA_VERSION, 0.1));
    let _ = std::fs::remove_dir_all(&dir);
}

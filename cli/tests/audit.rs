//! `stiction audit`: the batch's rows in an SQLite database, each registration once; a second
//! run adds nothing; a newer database is refused with one line; bad options are bad usage.

#![allow(clippy::unwrap_used)]

mod common;

use std::path::Path;

use common::{run, run_ok, temp_dir};

/// Two simulated registrations of valve V1 (the CLI's `simulate`, 500 samples) and a file the
/// reader refuses.
fn registrations(dir: &Path) {
    for (k, s) in ["2", "5"].iter().enumerate() {
        let out = dir.join(format!("V1_2024010{}-0800.csv", k + 1));
        run_ok(
            &[
                "simulate",
                "--valve",
                "kano",
                "--param",
                &format!("S={s}"),
                "--param",
                "J=1",
                "--samples",
                "500",
                "--seed",
                &format!("{}", k + 3),
                "-o",
                out.to_str().unwrap(),
            ],
            b"",
        );
    }
    std::fs::write(dir.join("V1_20240301-0800.csv"), "t,SP,PV,OP\n0,1,2,x\n").unwrap();
}

#[test]
fn audit_appends_each_registration_once() {
    let dir = temp_dir("audit");
    registrations(&dir);
    let db = dir.join("audit.sqlite");
    let args = [
        "audit",
        dir.to_str().unwrap(),
        "--db",
        db.to_str().unwrap(),
        "--stiction",
        "kano,he",
        "--step",
        "1",
    ];
    let first = run_ok(&args, b"");
    assert_eq!(
        first.stdout,
        "audit: 3 registration(s): 3 computed, 0 already in audit.sqlite; 6 row(s) added, 6 in the database\n"
    );
    let second = run_ok(&args, b"");
    assert_eq!(
        second.stdout,
        "audit: 3 registration(s): 0 computed, 3 already in audit.sqlite; 0 row(s) added, 6 in the database\n"
    );
    let store = audit::Store::open(&db).unwrap();
    assert_eq!(store.count().unwrap(), 6);
    let valves = store.valves().unwrap();
    assert_eq!(valves.len(), 1);
    let regs = &valves[0].registrations;
    assert_eq!(regs.len(), 3);
    assert!(regs[0].ok && regs[1].ok && !regs[2].ok);
    assert!(regs[2].error.is_some());
    drop(store);

    // --valve keeps that valve's files only.
    let other = run_ok(
        &[
            "audit",
            dir.to_str().unwrap(),
            "--db",
            db.to_str().unwrap(),
            "--valve",
            "V9",
        ],
        b"",
    );
    assert!(
        other.stdout.starts_with("audit: 0 registration(s)"),
        "{}",
        other.stdout
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_newer_database_is_bad_data_and_an_unknown_model_bad_usage() {
    let dir = temp_dir("audit-errors");
    registrations(&dir);
    let db = dir.join("audit.sqlite");
    drop(audit::Store::open(&db).unwrap());
    assert!(bump_schema_version(&db));
    let out = run(
        &["audit", dir.to_str().unwrap(), "--db", db.to_str().unwrap()],
        b"",
    );
    assert_eq!(out.code, 1);
    assert_eq!(out.stderr.lines().count(), 1, "{}", out.stderr);
    assert!(out.stderr.starts_with("error: "), "{}", out.stderr);
    assert!(
        out.stderr.contains(&format!(
            "schema version {} is newer",
            audit::SCHEMA_VERSION + 1
        )),
        "{}",
        out.stderr
    );

    let out = run(
        &[
            "audit",
            dir.to_str().unwrap(),
            "--db",
            db.to_str().unwrap(),
            "--stiction",
            "nope",
        ],
        b"",
    );
    assert_eq!(out.code, 2, "{}", out.stderr);
    let out = run(&["audit", dir.to_str().unwrap()], b"");
    assert_eq!(out.code, 2, "{}", out.stderr);
    assert!(out.stderr.contains("--db"), "{}", out.stderr);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Set the database's `user_version` to 2 by editing its header (bytes 60-63, big-endian),
/// without an SQLite client in this crate's tests.
fn bump_schema_version(db: &Path) -> bool {
    let mut bytes = std::fs::read(db).unwrap();
    // A WAL database may hold the header's latest version in its -wal file: checkpointed
    // when the last connection closed, so the main file is current.
    if bytes.len() < 100 || &bytes[..16] != b"SQLite format 3\0" {
        return false;
    }
    let newer = audit::SCHEMA_VERSION as u32 + 1;
    bytes[60..64].copy_from_slice(&newer.to_be_bytes());
    std::fs::write(db, bytes).unwrap();
    true
}

#[test]
fn the_fleet_page_ranks_every_valve_and_links_its_latest_registration() {
    let dir = temp_dir("audit-fleet");
    registrations(&dir);
    // a second valve, healthy
    let healthy = dir.join("V2_20240105-0800.csv");
    run_ok(
        &[
            "simulate",
            "--valve",
            "kano",
            "--param",
            "S=0",
            "--param",
            "J=0",
            "--samples",
            "500",
            "--seed",
            "9",
            "-o",
            healthy.to_str().unwrap(),
        ],
        b"",
    );
    let db = dir.join("audit.sqlite");
    let site = dir.join("site");
    let (d, dbs, sites) = (
        dir.to_str().unwrap(),
        db.to_str().unwrap(),
        site.to_str().unwrap(),
    );
    let out = run_ok(
        &["audit", d, "--db", dbs, "--step", "0.5", "--report", sites],
        b"",
    );
    assert!(out.stderr.contains("report: "), "{}", out.stderr);
    assert!(
        out.stderr.contains("(2 valves, 1 registration pages"),
        "{}",
        out.stderr
    );
    let page = std::fs::read_to_string(site.join("index.html")).unwrap();
    // each valve once; V1's latest registration is the unreadable one: its error, no link
    assert_eq!(page.matches(">V1<").count(), 1, "{page}");
    assert_eq!(page.matches(">V2<").count(), 1, "{page}");
    assert!(page.contains("valves/V2/index.html"), "{page}");
    assert!(!page.contains("valves/V1/index.html"), "{page}");
    assert!(site.join("valves/V2/index.html").exists());
    let linked = std::fs::read_to_string(site.join("valves/V2/index.html")).unwrap();
    assert!(
        linked.contains("Repair: "),
        "the latest registration's page says what a repair buys"
    );
    // from the database alone, the same page
    std::fs::remove_dir_all(&site).unwrap();
    let again = run_ok(&["audit", "--db", dbs, "--report", sites], b"");
    // no run without PATH: the ranking's top only
    assert!(again.stdout.starts_with("  #  valve "), "{}", again.stdout);
    assert_eq!(again.stdout.lines().count(), 3, "{}", again.stdout);
    assert_eq!(
        std::fs::read_to_string(site.join("index.html")).unwrap(),
        page
    );
    // --diagnose: the latest registration's page is its diagnosis, the causes the diagnosis'
    std::fs::remove_dir_all(&site).unwrap();
    run_ok(
        &[
            "audit",
            "--db",
            dbs,
            "--report",
            sites,
            "--diagnose",
            "--step",
            "0.5",
        ],
        b"",
    );
    let linked = std::fs::read_to_string(site.join("valves/V2/index.html")).unwrap();
    assert!(linked.contains("diagnose: loop"), "the diagnosis page");
    assert!(linked.contains("Repair: "), "with what a repair buys");
    let page = std::fs::read_to_string(site.join("index.html")).unwrap();
    assert!(
        page.contains("no-stiction") || page.contains("none (the baseline explains PV)"),
        "the healthy valve's causes are the diagnosis': {page}"
    );
    let needs_report = run(&["audit", "--db", dbs, "--diagnose"], b"");
    assert_eq!(needs_report.code, 2, "{}", needs_report.stderr);
    // no database and no PATH: an error
    let none = run(
        &[
            "audit",
            "--db",
            dir.join("nope.sqlite").to_str().unwrap(),
            "--report",
            sites,
        ],
        b"",
    );
    assert_eq!(none.code, 1, "{}", none.stderr);
    assert!(none.stderr.contains("no such database"), "{}", none.stderr);
    let _ = std::fs::remove_dir_all(&dir);
}

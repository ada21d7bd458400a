//! Writing the reports to check: the CLI built once, its reports on the paper loop, simulated
//! loops, the shared plant data, the audit pages and the trends.

use super::*;

/// Builds the CLI and writes the reports; returns the `index.html` files that exist. Commands
/// that fail are recorded in `failures` (with their stderr) and generation goes on.
pub(crate) fn generate(args: &Args, failures: &mut Vec<(String, String)>) -> Result<Vec<PathBuf>> {
    let exe = build_cli(&args.profile)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let mut pages = Vec::new();

    let detect_loop = args.out.join("sticky-loop.csv");
    let detect_args: Vec<std::ffi::OsString> =
        vec!["detect".into(), detect_loop.clone().into_os_string()];
    let mut runs: Vec<(&str, Vec<std::ffi::OsString>)> = REPORTS
        .iter()
        .map(|(name, cli_args)| (*name, cli_args.iter().map(Into::into).collect()))
        .collect();
    match simulate_loop(&exe, &detect_loop) {
        Ok(()) => runs.push(("detect", detect_args)),
        Err(e) => failures.push((format!("stiction {DETECT_LOOP}"), format!("{e:#}"))),
    }

    for (name, cli_args) in &runs {
        let dir = args.out.join(name);
        let started = Instant::now();
        let run = run_report(&exe, cli_args.iter().map(|s| s.as_os_str()), &dir)?;
        let secs = started.elapsed().as_secs_f64();
        let index = dir.join("index.html");
        let has_index = index.is_file();
        if run.success {
            if has_index {
                eprintln!("report-check: {} ({secs:.1} s)", run.command);
                pages.push(index);
            } else {
                failures.push((
                    run.command.clone(),
                    format!("exited successfully but wrote no {}", index.display()),
                ));
            }
        } else {
            eprintln!("report-check: FAILED {} ({})", run.command, run.status);
            failures.push(run.failure());
            if has_index {
                pages.push(index);
            }
        }
    }

    if let Some(plant) = &args.plant {
        pages.extend(generate_plant(
            &exe,
            plant,
            &args.out.join("plant"),
            failures,
        )?);
        pages.extend(generate_trends(
            &exe,
            plant,
            &args.out.join("trend"),
            failures,
        )?);
        pages.extend(generate_audit(
            &exe,
            plant,
            &args.out.join("plant-fleet"),
            failures,
        )?);
    }
    Ok(pages)
}

/// `stiction audit PLANT --db OUT.sqlite --report OUT`: the fleet page of the plant data and
/// the page of each valve's latest registration.
pub(crate) fn generate_audit(
    exe: &Path,
    plant: &Path,
    out: &Path,
    failures: &mut Vec<(String, String)>,
) -> Result<Vec<PathBuf>> {
    let mut db = out.as_os_str().to_owned();
    db.push(".sqlite");
    let db = PathBuf::from(db);
    for suffix in ["", "-wal", "-shm"] {
        let mut p = db.as_os_str().to_owned();
        p.push(suffix);
        let _ = std::fs::remove_file(PathBuf::from(p));
    }
    let started = Instant::now();
    let cli_args: [&std::ffi::OsStr; 4] = [
        "audit".as_ref(),
        plant.as_os_str(),
        "--db".as_ref(),
        db.as_os_str(),
    ];
    let run = run_report(exe, cli_args.into_iter(), out)?;
    eprintln!(
        "report-check: {} ({:.1} s)",
        run.command,
        started.elapsed().as_secs_f64()
    );
    let index = out.join("index.html");
    if !(run.success && index.is_file()) {
        failures.push(run.failure());
        return Ok(Vec::new());
    }
    let mut pages = vec![index];
    if let Ok(entries) = std::fs::read_dir(out.join("valves")) {
        let mut valves: Vec<PathBuf> = entries
            .filter_map(|e| e.ok().map(|e| e.path().join("index.html")))
            .filter(|p| p.is_file())
            .collect();
        valves.sort();
        pages.extend(valves);
    }
    Ok(pages)
}

/// `stiction simulate DETECT_LOOP -o csv`: the loop the `detect` page is checked on.
pub(crate) fn simulate_loop(exe: &Path, csv: &Path) -> Result<()> {
    let out = Command::new(exe)
        .args(DETECT_LOOP.split_whitespace())
        .arg("-o")
        .arg(csv)
        .stdin(Stdio::null())
        .output()
        .with_context(|| format!("could not start {}", exe.display()))?;
    if !out.status.success() {
        bail!(
            "failed ({}); its stderr:\n{}",
            out.status,
            tail(&String::from_utf8_lossy(&out.stderr), 30)
        );
    }
    Ok(())
}

/// `stiction trend DIR --valve TAG --report OUT/TAG` for every valve with two or more
/// registrations in `plant` (valve = file-name prefix before `_`).
pub(crate) fn generate_trends(
    exe: &Path,
    plant: &Path,
    out: &Path,
    failures: &mut Vec<(String, String)>,
) -> Result<Vec<PathBuf>> {
    let mut count: std::collections::BTreeMap<String, usize> = Default::default();
    for entry in std::fs::read_dir(plant).with_context(|| format!("reading {}", plant.display()))? {
        let path = entry?.path();
        if path.extension().and_then(|e| e.to_str()) != Some("csv") {
            continue;
        }
        let name = path.file_stem().and_then(|s| s.to_str()).unwrap_or("");
        if let Some((valve, _)) = name.split_once('_') {
            *count.entry(valve.to_string()).or_default() += 1;
        }
    }
    let mut pages = Vec::new();
    for (valve, n) in count.into_iter().filter(|(_, n)| *n >= 2) {
        let dir = out.join(&valve);
        let started = Instant::now();
        let plant_arg = plant.display().to_string();
        let run = run_report(
            exe,
            ["trend", plant_arg.as_str(), "--valve", valve.as_str()]
                .into_iter()
                .map(std::ffi::OsStr::new),
            &dir,
        )?;
        let index = dir.join("index.html");
        eprintln!(
            "report-check: {} ({n} registrations, {:.1} s)",
            run.command,
            started.elapsed().as_secs_f64()
        );
        if run.success && index.is_file() {
            pages.push(index);
        } else {
            failures.push((
                run.command.clone(),
                format!(
                    "exit {}, index.html written: {}; its stderr:\n{}",
                    run.status,
                    index.is_file(),
                    tail(&run.stderr, 30)
                ),
            ));
        }
    }
    Ok(pages)
}

/// `cargo build --profile PROFILE -p stiction-cli --bin stiction`; returns the binary's path.
/// (`test` reuses what `cargo xtask test` built, which is how CI runs the check.)
pub(crate) fn build_cli(profile: &str) -> Result<PathBuf> {
    crate::status(crate::cargo().args([
        "build",
        "--profile",
        profile,
        "-p",
        "stiction-cli",
        "--bin",
        "stiction",
    ]))?;
    let dir = match profile {
        "dev" | "test" => "debug",
        "bench" => "release",
        other => other,
    };
    let exe = target_dir()?
        .join(dir)
        .join(format!("stiction{}", std::env::consts::EXE_SUFFIX));
    if !exe.is_file() {
        bail!(
            "`cargo build --profile {profile} -p stiction-cli` succeeded but {} does not exist",
            exe.display()
        );
    }
    Ok(exe)
}

/// Cargo's target directory (honours `CARGO_TARGET_DIR` and `build.target-dir`).
pub(crate) fn target_dir() -> Result<PathBuf> {
    let mut cmd = crate::cargo();
    cmd.args(["metadata", "--format-version", "1", "--no-deps"]);
    let out = cmd
        .output()
        .with_context(|| format!("could not start {cmd:?}"))?;
    if !out.status.success() {
        bail!(
            "{cmd:?} failed ({}):\n{}",
            out.status,
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let meta: Value = serde_json::from_slice(&out.stdout).context("parsing `cargo metadata`")?;
    let dir = meta["target_directory"]
        .as_str()
        .context("`cargo metadata` has no target_directory")?;
    Ok(PathBuf::from(dir))
}

/// What one `stiction ... --report DIR` run did.
pub(crate) struct ReportRun {
    /// The command line, for messages.
    pub(crate) command: String,
    pub(crate) success: bool,
    /// Exit status, for messages.
    pub(crate) status: String,
    pub(crate) stderr: String,
}

impl ReportRun {
    /// The failure's entry: the command, and its status with the tail of its stderr.
    pub(crate) fn failure(&self) -> (String, String) {
        (
            self.command.clone(),
            format!(
                "failed ({}); its stderr:\n{}",
                self.status,
                tail(&self.stderr, 30)
            ),
        )
    }
}

/// Runs `stiction ARGS --report DIR` into a fresh `DIR` (an old `DIR` is removed first, so a
/// stale `index.html` cannot pass for a new one).
pub(crate) fn run_report<'a>(
    exe: &Path,
    cli_args: impl Iterator<Item = &'a std::ffi::OsStr>,
    dir: &Path,
) -> Result<ReportRun> {
    if dir.exists() {
        std::fs::remove_dir_all(dir)
            .with_context(|| format!("removing the old report {}", dir.display()))?;
    }
    if let Some(parent) = dir.parent() {
        std::fs::create_dir_all(parent)
            .with_context(|| format!("creating {}", parent.display()))?;
    }
    let mut cmd = Command::new(exe);
    cmd.args(cli_args).arg("--report").arg(dir);
    let command = format!(
        "stiction {}",
        cmd.get_args()
            .map(|a| a.to_string_lossy().into_owned())
            .collect::<Vec<_>>()
            .join(" ")
    );
    let out = cmd
        .stdin(Stdio::null())
        .output()
        .with_context(|| format!("could not start {}", exe.display()))?;
    Ok(ReportRun {
        command,
        success: out.status.success(),
        status: out.status.to_string(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    })
}

/// The last `n` lines of `s`, indented, or a note that it is empty.
pub(crate) fn tail(s: &str, n: usize) -> String {
    let lines: Vec<&str> = s.lines().collect();
    if lines.is_empty() {
        return "    (nothing on stderr)".to_string();
    }
    let skip = lines.len().saturating_sub(n);
    let mut out = String::new();
    if skip > 0 {
        out.push_str(&format!("    ... ({skip} earlier lines)\n"));
    }
    let shown: Vec<String> = lines[skip..].iter().map(|l| format!("    {l}")).collect();
    out.push_str(&shown.join("\n"));
    out
}

/// Does the first line of the CSV file name an `OP` column? (`labels.csv` does not.)
pub(crate) fn has_op_column(path: &Path) -> Result<bool> {
    let file = std::fs::File::open(path).with_context(|| format!("opening {}", path.display()))?;
    let mut header = String::new();
    BufReader::new(file)
        .read_line(&mut header)
        .with_context(|| format!("reading the header of {}", path.display()))?;
    Ok(header
        .split(',')
        .any(|c| c.trim().trim_matches('"').eq_ignore_ascii_case("op")))
}

/// `stiction diagnose FILE --report OUT/STEM` for every loop CSV in `plant`, [`PLANT_JOBS`] at
/// a time. A non-zero exit is fine if the report (explaining the refusal) was written.
pub(crate) fn generate_plant(
    exe: &Path,
    plant: &Path,
    out: &Path,
    failures: &mut Vec<(String, String)>,
) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(plant).with_context(|| format!("listing {}", plant.display()))? {
        let path = entry
            .with_context(|| format!("listing {}", plant.display()))?
            .path();
        if path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("csv"))
        {
            if has_op_column(&path)? {
                files.push(path);
            } else {
                eprintln!(
                    "report-check: skipping {} (no OP column)",
                    path.file_name().unwrap_or_default().to_string_lossy()
                );
            }
        }
    }
    files.sort();
    if files.is_empty() {
        bail!("--plant {}: no CSV file with an OP column", plant.display());
    }

    let n = files.len();
    let done = AtomicUsize::new(0);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(PLANT_JOBS)
        .build()
        .context("starting the worker threads")?;
    let results: Vec<Result<(PathBuf, ReportRun, f64)>> = pool.install(|| {
        use rayon::prelude::*;
        files
            .par_iter()
            .map(|file| {
                let stem = file
                    .file_stem()
                    .with_context(|| format!("{} has no file name", file.display()))?;
                let dir = out.join(stem);
                let started = Instant::now();
                let args = [std::ffi::OsStr::new("diagnose"), file.as_os_str()];
                let run = run_report(exe, args.into_iter(), &dir)?;
                let secs = started.elapsed().as_secs_f64();
                let k = done.fetch_add(1, Ordering::SeqCst) + 1;
                let what = match (run.success, dir.join("index.html").is_file()) {
                    (true, true) => "report written".to_string(),
                    (false, true) => format!("{}, refusal report written", run.status),
                    (true, false) => "FAILED: exited successfully but no index.html".to_string(),
                    (false, false) => format!("FAILED: {}, no index.html", run.status),
                };
                eprintln!(
                    "report-check: [{k:>w$}/{n}] {}: {what} ({secs:.1} s)",
                    stem.to_string_lossy(),
                    w = n.to_string().len()
                );
                Ok((dir, run, secs))
            })
            .collect()
    });

    let mut pages = Vec::new();
    for r in results {
        let (dir, run, _) = r?;
        let index = dir.join("index.html");
        if index.is_file() {
            pages.push(index);
        } else {
            failures.push((
                run.command.clone(),
                format!(
                    "wrote no {} ({}); its stderr:\n{}",
                    index.display(),
                    run.status,
                    tail(&run.stderr, 10)
                ),
            ));
        }
    }
    Ok(pages)
}

//! The headless Chromium process and the DevTools connection to it.

use super::*;

/// A directory under the system temp dir, removed on drop.
pub(crate) struct TempDir(PathBuf);

impl TempDir {
    pub(crate) fn new(prefix: &str) -> Result<Self> {
        let nanos = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map(|d| d.as_nanos())
            .unwrap_or(0);
        let path = std::env::temp_dir().join(format!("{prefix}-{}-{nanos}", std::process::id()));
        std::fs::create_dir(&path).with_context(|| format!("creating {}", path.display()))?;
        Ok(TempDir(path))
    }

    pub(crate) fn path(&self) -> &Path {
        &self.0
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        // Chromium's helper processes may still be writing to the profile for a moment.
        for _ in 0..20 {
            if std::fs::remove_dir_all(&self.0).is_ok() || !self.0.exists() {
                return;
            }
            std::thread::sleep(Duration::from_millis(100));
        }
        eprintln!("report-check: could not remove {}", self.0.display());
    }
}

/// A running headless Chromium and the DevTools connection to it. Dropping it closes the
/// browser (killing it if it does not exit) and removes its temporary profile.
pub(crate) struct Browser {
    pub(crate) cdp: Option<Cdp>,
    pub(crate) child: Child,
    /// Declared after `child` so the profile is removed after the browser has exited.
    pub(crate) _profile: TempDir,
}

impl Browser {
    pub(crate) fn launch(exe: &Path) -> Result<Self> {
        let profile = TempDir::new("stiction-report-check-profile")?;
        let child = Command::new(exe)
            .args(CHROMIUM_FLAGS)
            .arg(format!("--user-data-dir={}", profile.path().display()))
            .arg("about:blank")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .with_context(|| format!("could not start {}", exe.display()))?;
        let mut browser = Browser {
            cdp: None,
            child,
            _profile: profile,
        };
        let stderr = browser
            .child
            .stderr
            .take()
            .context("Chromium's stderr is not captured")?;

        // Read stderr in a thread for the whole life of the browser (a full pipe would block
        // it); pass on the DevTools address, keep the last lines for error messages.
        let last_lines = Arc::new(Mutex::new(VecDeque::new()));
        let (tx, rx) = mpsc::channel();
        {
            let last_lines = Arc::clone(&last_lines);
            std::thread::spawn(move || {
                for line in BufReader::new(stderr).lines() {
                    let Ok(line) = line else { break };
                    if let Some((_, url)) = line.split_once("DevTools listening on ") {
                        let _ = tx.send(url.trim().to_string());
                    }
                    if let Ok(mut q) = last_lines.lock() {
                        if q.len() == 20 {
                            q.pop_front();
                        }
                        q.push_back(line);
                    }
                }
            });
        }
        let url = match rx.recv_timeout(LAUNCH_TIMEOUT) {
            Ok(url) => url,
            Err(e) => {
                let why = match e {
                    mpsc::RecvTimeoutError::Timeout => {
                        format!("did not print its DevTools address within {LAUNCH_TIMEOUT:?}")
                    }
                    mpsc::RecvTimeoutError::Disconnected => {
                        let status = browser.child.wait().map(|s| s.to_string());
                        format!(
                            "exited ({}) without printing its DevTools address",
                            status.unwrap_or_else(|e| e.to_string())
                        )
                    }
                };
                let lines = last_lines
                    .lock()
                    .map(|q| q.iter().cloned().collect::<Vec<_>>().join("\n    "))
                    .unwrap_or_default();
                bail!(
                    "Chromium ({}) {why}; its last stderr lines:\n    {lines}",
                    exe.display()
                );
            }
        };
        browser.cdp = Some(Cdp::connect(&url)?);
        Ok(browser)
    }

    pub(crate) fn cdp(&mut self) -> Result<&mut Cdp> {
        self.cdp.as_mut().context("no DevTools connection")
    }

    /// Loads `page` in a new tab, checks it and saves a full-page screenshot to `shot`.
    /// `Err` means the check itself could not be done (timeout, browser gone).
    pub(crate) fn check_page(&mut self, page: &Path, shot: &Path) -> Result<PageReport> {
        let started = Instant::now();
        let mut report = PageReport::default();
        let abs = match std::fs::canonicalize(page) {
            Ok(p) if p.is_file() => p,
            _ => {
                report
                    .problems
                    .push(format!("{} does not exist", page.display()));
                return Ok(report);
            }
        };
        let url = file_url(&abs)?;
        self.in_new_tab(started + PAGE_TIMEOUT, |cdp, target_id, deadline| {
            cdp.check_in_target(target_id, &url, shot, deadline, &mut report)
        })?;
        report.elapsed = started.elapsed();
        Ok(report)
    }

    /// Runs `f` in a new tab (target) and closes the tab whatever happened.
    pub(crate) fn in_new_tab<T>(
        &mut self,
        deadline: Instant,
        f: impl FnOnce(&mut Cdp, &str, Instant) -> Result<T>,
    ) -> Result<T> {
        let cdp = self.cdp()?;
        let target = cdp.call(
            None,
            "Target.createTarget",
            json!({ "url": "about:blank" }),
            deadline,
            &mut Vec::new(),
        )?;
        let target_id = target["targetId"]
            .as_str()
            .context("Target.createTarget returned no targetId")?
            .to_string();
        let result = f(cdp, &target_id, deadline);
        // Close the tab whatever happened (with a fresh deadline: the page's may be spent).
        let closed = cdp.call(
            None,
            "Target.closeTarget",
            json!({ "targetId": target_id }),
            Instant::now() + Duration::from_secs(5),
            &mut Vec::new(),
        );
        let value = result?;
        closed?;
        Ok(value)
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        if let Some(cdp) = self.cdp.as_mut() {
            let _ = cdp.send(None, "Browser.close", json!({}));
        }
        let deadline = Instant::now() + Duration::from_secs(5);
        loop {
            match self.child.try_wait() {
                Ok(Some(_)) => break,
                Ok(None) if Instant::now() < deadline => {
                    std::thread::sleep(Duration::from_millis(50));
                }
                _ => {
                    let _ = self.child.kill();
                    let _ = self.child.wait();
                    break;
                }
            }
        }
        self.cdp = None;
    }
}

/// `file://` URL of an absolute path (percent-encoding everything but unreserved characters
/// and `/`).
pub(crate) fn file_url(abs: &Path) -> Result<String> {
    let s = abs
        .to_str()
        .with_context(|| format!("{} is not valid UTF-8", abs.display()))?;
    let mut url = String::from("file://");
    for b in s.bytes() {
        if b.is_ascii_alphanumeric() || b"/-._~".contains(&b) {
            url.push(char::from(b));
        } else {
            url.push_str(&format!("%{b:02X}"));
        }
    }
    Ok(url)
}

/// A synchronous DevTools protocol client over the browser's websocket.
pub(crate) struct Cdp {
    pub(crate) ws: WebSocket<TcpStream>,
    pub(crate) next_id: u64,
}

impl Cdp {
    /// Connects to `ws://HOST:PORT/devtools/browser/ID`.
    pub(crate) fn connect(url: &str) -> Result<Self> {
        let host_port = url
            .strip_prefix("ws://")
            .and_then(|rest| rest.split('/').next())
            .with_context(|| format!("unexpected DevTools address {url:?}"))?;
        let stream = TcpStream::connect(host_port)
            .with_context(|| format!("connecting to Chromium's DevTools at {host_port}"))?;
        stream
            .set_read_timeout(Some(LAUNCH_TIMEOUT))
            .context("setting a socket timeout")?;
        stream
            .set_write_timeout(Some(PAGE_TIMEOUT))
            .context("setting a socket timeout")?;
        // Screenshots of long pages come as one large message.
        let config = WebSocketConfig::default()
            .max_message_size(Some(512 << 20))
            .max_frame_size(Some(512 << 20));
        let (ws, _) = tungstenite::client::client_with_config(url, stream, Some(config))
            .map_err(|e| anyhow::anyhow!("{e}"))
            .with_context(|| format!("websocket handshake with {url}"))?;
        Ok(Cdp { ws, next_id: 1 })
    }

    /// Sends a command (to the page session `session`, or to the browser); returns its id.
    pub(crate) fn send(
        &mut self,
        session: Option<&str>,
        method: &str,
        params: Value,
    ) -> Result<u64> {
        let id = self.next_id;
        self.next_id += 1;
        let mut msg = json!({ "id": id, "method": method, "params": params });
        if let Some(s) = session {
            msg["sessionId"] = json!(s);
        }
        self.ws
            .send(Message::Text(msg.to_string().into()))
            .with_context(|| format!("sending {method} to Chromium"))?;
        Ok(id)
    }

    /// The next JSON message from the browser, or an error once `deadline` has passed.
    pub(crate) fn next_message(&mut self, deadline: Instant) -> Result<Value> {
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                bail!("timed out (page limit {PAGE_TIMEOUT:?})");
            }
            self.ws
                .get_mut()
                .set_read_timeout(Some(left.max(Duration::from_millis(1))))
                .context("setting a socket timeout")?;
            match self.ws.read() {
                Ok(Message::Text(t)) => {
                    return serde_json::from_str(t.as_str()).context("parsing a DevTools message")
                }
                Ok(Message::Binary(b)) => {
                    return serde_json::from_slice(&b).context("parsing a DevTools message")
                }
                Ok(Message::Close(_)) => bail!("Chromium closed the DevTools connection"),
                Ok(_) => {}
                Err(tungstenite::Error::Io(e))
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                    ) =>
                {
                    bail!("timed out (page limit {PAGE_TIMEOUT:?})")
                }
                Err(e) => return Err(e).context("reading from Chromium's DevTools connection"),
            }
        }
    }

    /// Sends a command and waits for its result. Events of `session` that arrive meanwhile
    /// are appended to `events`; other messages are dropped.
    pub(crate) fn call(
        &mut self,
        session: Option<&str>,
        method: &str,
        params: Value,
        deadline: Instant,
        events: &mut Vec<Value>,
    ) -> Result<Value> {
        let id = self.send(session, method, params)?;
        loop {
            let msg = self
                .next_message(deadline)
                .with_context(|| format!("waiting for the reply to {method}"))?;
            if msg["id"].as_u64() == Some(id) {
                if let Some(err) = msg.get("error") {
                    bail!("{method} failed: {err}");
                }
                return Ok(msg["result"].clone());
            }
            self.keep_event(session, msg, events);
        }
    }

    /// Waits until `events[from..]` holds an event `method` of `session`.
    pub(crate) fn wait_event(
        &mut self,
        session: &str,
        method: &str,
        from: usize,
        deadline: Instant,
        events: &mut Vec<Value>,
    ) -> Result<()> {
        loop {
            if events
                .iter()
                .skip(from)
                .any(|e| e["method"].as_str() == Some(method))
            {
                return Ok(());
            }
            let msg = self
                .next_message(deadline)
                .with_context(|| format!("waiting for {method}"))?;
            self.keep_event(Some(session), msg, events);
        }
    }

    pub(crate) fn keep_event(&self, session: Option<&str>, msg: Value, events: &mut Vec<Value>) {
        if session.is_some() && msg["sessionId"].as_str() == session && msg.get("method").is_some()
        {
            events.push(msg);
        }
    }

    /// Attaches to the tab `target_id` (flat session), enables the page, runtime and log
    /// events and sets the viewport; returns the session id.
    pub(crate) fn attach(
        &mut self,
        target_id: &str,
        deadline: Instant,
        events: &mut Vec<Value>,
    ) -> Result<String> {
        let attached = self.call(
            None,
            "Target.attachToTarget",
            json!({ "targetId": target_id, "flatten": true }),
            deadline,
            events,
        )?;
        let session = attached["sessionId"]
            .as_str()
            .context("Target.attachToTarget returned no sessionId")?
            .to_string();
        let s = Some(session.as_str());
        for domain in ["Page.enable", "Runtime.enable", "Log.enable"] {
            self.call(s, domain, json!({}), deadline, events)?;
        }
        self.call(
            s,
            "Emulation.setDeviceMetricsOverride",
            json!({ "width": VIEWPORT.0, "height": VIEWPORT.1, "deviceScaleFactor": 1, "mobile": false }),
            deadline,
            events,
        )?;
        Ok(session)
    }

    /// Navigates the session's tab to `url` and waits for its load event. `Ok(Some(text))` when
    /// the navigation itself failed.
    pub(crate) fn navigate(
        &mut self,
        session: &str,
        url: &str,
        deadline: Instant,
        events: &mut Vec<Value>,
    ) -> Result<Option<String>> {
        let from = events.len();
        let nav = self.call(
            Some(session),
            "Page.navigate",
            json!({ "url": url }),
            deadline,
            events,
        )?;
        if let Some(err) = nav["errorText"].as_str() {
            return Ok(Some(err.to_string()));
        }
        self.wait_event(session, "Page.loadEventFired", from, deadline, events)?;
        Ok(None)
    }

    /// Evaluates `expression` in the page and returns its value (by value); an exception in
    /// the expression is an error.
    pub(crate) fn evaluate(
        &mut self,
        session: &str,
        expression: &str,
        deadline: Instant,
        events: &mut Vec<Value>,
    ) -> Result<Value> {
        let eval = self.call(
            Some(session),
            "Runtime.evaluate",
            json!({ "expression": expression, "returnByValue": true }),
            deadline,
            events,
        )?;
        if let Some(ex) = eval.get("exceptionDetails") {
            bail!("the script failed: {ex}");
        }
        Ok(eval["result"]["value"].clone())
    }

    /// Full-page screenshot of the session's tab into `shot`.
    pub(crate) fn screenshot(
        &mut self,
        session: &str,
        shot: &Path,
        deadline: Instant,
        events: &mut Vec<Value>,
        report: &mut PageReport,
    ) -> Result<()> {
        let s = Some(session);
        let metrics = self.call(s, "Page.getLayoutMetrics", json!({}), deadline, events)?;
        let size = &metrics["cssContentSize"];
        let width = size["width"]
            .as_f64()
            .unwrap_or(0.0)
            .max(f64::from(VIEWPORT.0))
            .ceil();
        let full_height = size["height"].as_f64().unwrap_or(0.0).ceil();
        let height = full_height.clamp(1.0, MAX_SCREENSHOT_HEIGHT);
        if height < full_height {
            report.screenshot_note = Some(format!("(cut at {height} of {full_height} px)"));
        }
        let png = self.call(
            s,
            "Page.captureScreenshot",
            json!({
                "format": "png",
                "captureBeyondViewport": true,
                "clip": { "x": 0, "y": 0, "width": width, "height": height, "scale": 1 },
            }),
            deadline,
            events,
        )?;
        let data = png["data"]
            .as_str()
            .context("Page.captureScreenshot returned no data")?;
        let bytes = base64::engine::general_purpose::STANDARD
            .decode(data)
            .context("decoding the screenshot")?;
        std::fs::write(shot, bytes).with_context(|| format!("writing {}", shot.display()))?;
        report.screenshot = Some(shot.to_path_buf());
        Ok(())
    }

    /// Attaches to the tab `target_id`, loads `url`, measures, screenshots; fills `report`.
    pub(crate) fn check_in_target(
        &mut self,
        target_id: &str,
        url: &str,
        shot: &Path,
        deadline: Instant,
        report: &mut PageReport,
    ) -> Result<()> {
        let mut events = Vec::new();
        let session = self.attach(target_id, deadline, &mut events)?;
        if let Some(err) = self.navigate(&session, url, deadline, &mut events)? {
            report.problems.push(format!("navigation failed: {err}"));
            return Ok(());
        }
        let value = self
            .evaluate(&session, MEASURE_JS, deadline, &mut events)
            .context("the measuring script")?;
        let m = Measured::from_json(&value);
        if m.href != url {
            report.problems.push(format!(
                "the tab shows {:?} instead of the page (readyState {})",
                m.href, m.ready_state
            ));
        }
        report.svgs = m.svgs.len();
        report.imgs = m.imgs.len();
        judge_figures(&m, report);
        self.screenshot(&session, shot, deadline, &mut events, report)?;
        judge_events(&events, report);
        Ok(())
    }
}

//! The protocol over in-memory buffers, against a scripted device.

use super::*;
use proptest::prelude::*;

/// A device whose commands take scripted simulated time:
/// `G4 S<s>` dwells `s` seconds, `M109` reports a temperature every second for 5 s,
/// `M112` halts until `M999`, `M105` prints its own `ok T:`, `G1` takes 0.5 s, anything else is
/// instant and silent. Idle time passes on its clock and is counted in `idle_s`.
#[derive(Default)]
pub(crate) struct Scripted {
    pub t_s: f64,
    pub ran: Vec<String>,
    pub idle_s: f64,
    halted: bool,
    acknowledged: bool,
}

impl Device for Scripted {
    fn boot_lines(&self) -> Vec<String> {
        vec!["start".into(), "echo:Marlin test double".into()]
    }

    fn execute(&mut self, line: &[u8], out: &mut dyn FnMut(f64, &str)) -> Outcome {
        let text = String::from_utf8_lossy(line).into_owned();
        self.ran.push(text.clone());
        let mut block = Block::default();
        parse_into(line, &mut block);
        self.acknowledged = block.command.is_m(105);
        if self.acknowledged {
            out(self.t_s, "ok T:20.00 /0.00");
        } else if block.command.is_m(999) {
            self.halted = false;
        } else if block.command.is_g(4) {
            self.t_s += block.get(b'S').unwrap_or(0.0);
        } else if block.command.is_g(1) {
            self.t_s += 0.5;
        } else if block.command.is_m(109) {
            for k in 1..=5 {
                self.t_s += 1.0;
                out(self.t_s, &format!(" T:{}.00 /200.00", 150 + 10 * k));
            }
        } else if block.command.is_m(112) {
            out(self.t_s, "Error:Printer halted. kill() called!");
            self.halted = true;
        }
        if self.halted {
            Outcome::Halted
        } else {
            Outcome::Ok
        }
    }

    fn now_s(&self) -> f64 {
        self.t_s
    }

    fn acknowledged(&self) -> bool {
        self.acknowledged
    }

    fn idle(&mut self, t_s: f64, _out: &mut dyn FnMut(f64, &str)) {
        self.t_s += t_s;
        self.idle_s += t_s;
    }
}

/// Replies with their times.
type Log = Vec<(f64, String)>;

fn session(config: ProtocolConfig) -> Protocol<Scripted> {
    Protocol::new(Scripted::default(), config)
}

fn send(p: &mut Protocol<Scripted>, bytes: &str) -> Log {
    let mut log = Log::new();
    p.feed(bytes.as_bytes(), &mut |t, l| log.push((t, l.to_string())));
    log
}

fn texts(log: &Log) -> Vec<&str> {
    log.iter().map(|(_, l)| l.as_str()).collect()
}

/// A stream of framed lines `N<from>..` with a newline each.
fn framed(from: i64, commands: &[&str]) -> String {
    commands.iter().zip(from..).map(|(c, n)| frame_line(n, c) + "\n").collect()
}

#[test]
fn reference_checksums() {
    assert_eq!(frame_line(0, "M110 N0"), "N0 M110 N0*125");
    assert_eq!(frame_line(1, "G28"), "N1 G28*18");
}

#[test]
fn boot_prints_start() {
    let mut p = session(ProtocolConfig::default());
    let mut log = Log::new();
    p.boot(&mut |t, l| log.push((t, l.to_string())));
    assert_eq!(log, [(0.0, "start".to_string()), (0.0, "echo:Marlin test double".to_string())]);
}

#[test]
fn every_command_gets_ok_and_runs_once() {
    let mut p = session(ProtocolConfig::default());
    let log = send(&mut p, "G28\nN1 G1 X1*96\nM105\n");
    assert_eq!(frame_line(1, "G1 X1"), "N1 G1 X1*96");
    assert_eq!(texts(&log), ["ok", "ok", "ok T:20.00 /0.00"]);
    assert_eq!(p.device().ran, ["G28", "G1 X1", "M105"]);
    assert_eq!(p.last_line_number(), 1);
    // The ok comes when the command ends in simulated time.
    assert_eq!(log[1].0, 0.5);
}

#[test]
fn line_number_error_exact() {
    let mut p = session(ProtocolConfig::default());
    send(&mut p, &framed(1, &["G28", "G90"]));
    let log = send(&mut p, &frame_line(4, "G91"));
    assert_eq!(log, []);
    let log = send(&mut p, "\n");
    assert_eq!(texts(&log), ["Error:Line Number is not Last Line Number+1, Last Line: 2", "Resend: 3", "ok"]);
    assert_eq!(p.device().ran.len(), 2);
    assert_eq!(p.stats().errors, 1);
}

#[test]
fn checksum_mismatch_exact() {
    let mut p = session(ProtocolConfig::default());
    let log = send(&mut p, "N1 G28*19\n");
    assert_eq!(texts(&log), ["Error:checksum mismatch, Last Line: 0", "Resend: 1", "ok"]);
    assert!(p.device().ran.is_empty());
    // A garbled checksum reads as 0 (strtol), which is also a mismatch here.
    let log = send(&mut p, "N1 G28*x\n");
    assert_eq!(texts(&log)[0], "Error:checksum mismatch, Last Line: 0");
}

#[test]
fn no_checksum_exact() {
    let mut p = session(ProtocolConfig::default());
    let log = send(&mut p, "N1 G28\n");
    assert_eq!(texts(&log), ["Error:No Checksum with line number, Last Line: 0", "Resend: 1", "ok"]);
    assert!(p.device().ran.is_empty());
}

#[test]
fn line_number_is_checked_before_checksum() {
    let mut p = session(ProtocolConfig::default());
    let log = send(&mut p, "N7 G28\n");
    assert_eq!(texts(&log)[0], "Error:Line Number is not Last Line Number+1, Last Line: 0");
}

#[test]
fn resend_sequence_runs_each_line_once_in_order() {
    let mut p = session(ProtocolConfig::default());
    let commands = ["G28", "G1 X1", "G1 X2", "G1 X3"];
    let mut log = send(&mut p, &framed(1, &commands[..2]));
    // Line 3 is corrupted on the wire (a flipped digit), the host resends it on request.
    let corrupt = frame_line(3, "G1 X2").replace("X2", "X3");
    log.extend(send(&mut p, &format!("{corrupt}\n")));
    assert_eq!(texts(&log)[2..], ["Error:checksum mismatch, Last Line: 2", "Resend: 3", "ok"]);
    log.extend(send(&mut p, &framed(3, &commands[2..])));
    assert_eq!(texts(&log).iter().filter(|l| **l == "ok").count(), 5);
    assert_eq!(p.device().ran, commands);
}

#[test]
fn m110_resets_numbered_and_unnumbered() {
    let mut p = session(ProtocolConfig::default());
    send(&mut p, &framed(1, &["G28", "G90"]));
    // OctoPrint's handshake, mid-stream: any number is accepted with M110.
    assert_eq!(texts(&send(&mut p, "N0 M110 N0*125\n")), ["ok"]);
    assert_eq!(p.last_line_number(), 0);
    assert_eq!(texts(&send(&mut p, &framed(1, &["G91"]))), ["ok"]);
    assert_eq!(texts(&send(&mut p, "M110 N100\n")), ["ok"]);
    assert_eq!(texts(&send(&mut p, &framed(101, &["G90"]))), ["ok"]);
    // `N5 M110` (no second N) takes the line's own number.
    send(&mut p, &format!("{}\n", frame_line(5, "M110")));
    assert_eq!(p.last_line_number(), 5);
    // The device never sees the link's own commands.
    assert_eq!(p.device().ran.len(), 4);
}

#[test]
fn m110_checksum_is_still_checked() {
    let mut p = session(ProtocolConfig::default());
    send(&mut p, &framed(1, &["G28"]));
    let log = send(&mut p, "N0 M110 N0*124\n");
    assert_eq!(texts(&log), ["Error:checksum mismatch, Last Line: 1", "Resend: 2", "ok"]);
    assert_eq!(p.last_line_number(), 1);
}

#[test]
fn duplicate_lines_are_acknowledged_not_rerun() {
    let mut p = session(ProtocolConfig::default());
    send(&mut p, &framed(1, &["G28", "G1 X1", "G1 X2", "G1 X3", "G1 X4"]));
    // The host repeats the last four lines after a resend race.
    let log = send(&mut p, &framed(2, &["G1 X1", "G1 X2", "G1 X3", "G1 X4"]));
    assert_eq!(texts(&log), ["ok", "ok", "ok", "ok"]);
    assert_eq!(p.device().ran.len(), 5);
    assert_eq!(p.stats().duplicates, 4);
    assert_eq!(p.last_line_number(), 5);
    // Older than the window: a line-number error, as Marlin.
    let log = send(&mut p, &framed(1, &["G28"]));
    assert_eq!(texts(&log)[1], "Resend: 6");
    // A corrupted duplicate is an error too, never silently dropped.
    let log = send(&mut p, "N5 G1 X4*0\n");
    assert_eq!(texts(&log)[0], "Error:Line Number is not Last Line Number+1, Last Line: 5");
}

#[test]
fn duplicate_window_zero_is_stock_marlin() {
    let mut p = session(ProtocolConfig { duplicate_window: 0, ..ProtocolConfig::default() });
    send(&mut p, &framed(1, &["G28"]));
    let log = send(&mut p, &framed(1, &["G28"]));
    assert_eq!(texts(&log), ["Error:Line Number is not Last Line Number+1, Last Line: 1", "Resend: 2", "ok"]);
}

#[test]
fn comments_and_empty_lines_get_no_reply() {
    let mut p = session(ProtocolConfig::default());
    assert_eq!(send(&mut p, "\n\r\n; just a comment\n   ;indented\n"), []);
    // The comment is dropped before the checksum is computed, and CRLF is one line.
    let log = send(&mut p, &format!("{} ; home all\r\n", frame_line(1, "G28")));
    assert_eq!(texts(&log), ["ok"]);
    assert_eq!(p.device().ran, ["G28"]);
    assert_eq!(p.stats().lines, 1);
}

#[test]
fn leading_spaces_are_skipped_for_checks() {
    let mut p = session(ProtocolConfig::default());
    assert_eq!(texts(&send(&mut p, "   N1 G28*18\n")), ["ok"]);
    assert_eq!(p.last_line_number(), 1);
}

#[test]
fn overlong_lines_are_refused() {
    let mut p = session(ProtocolConfig::default());
    let fits = format!("M117 {}", "a".repeat(MAX_LINE_BYTES - 5));
    assert_eq!(fits.len(), MAX_LINE_BYTES);
    assert_eq!(texts(&send(&mut p, &format!("{fits}\n"))), ["ok"]);
    assert_eq!(texts(&send(&mut p, &format!("{fits}b\n"))), ["Error:Line too long, Last Line: 0", "ok"]);
    // A long comment does not count.
    assert_eq!(texts(&send(&mut p, &format!("{fits};{}\n", "c".repeat(200)))), ["ok"]);
    let numbered = frame_line(1, &format!("M117 {}", "a".repeat(100)));
    let log = send(&mut p, &format!("{numbered}\n"));
    assert_eq!(texts(&log), ["Error:Line too long, Last Line: 0", "Resend: 1", "ok"]);
    assert_eq!(p.device().ran.len(), 2);
}

#[test]
fn a_20_mb_line_is_refused_without_being_buffered() {
    let mut p = session(ProtocolConfig::default());
    let chunk = vec![b'G'; 1 << 20];
    let mut log = Log::new();
    for _ in 0..20 {
        p.feed(&chunk, &mut |t, l| log.push((t, l.to_string())));
    }
    // Nothing is answered before the line ends, and the line buffer never grew past Marlin's.
    assert!(log.is_empty());
    assert!(p.assembler.line.capacity() <= MAX_LINE_BYTES, "{}", p.assembler.line.capacity());
    let log = send(&mut p, "\nM105\n");
    assert_eq!(texts(&log), ["Error:Line too long, Last Line: 0", "ok", "ok T:20.00 /0.00"]);
    assert_eq!(p.device().ran, ["M105"]);
}

#[test]
fn busy_every_two_simulated_seconds() {
    let mut p = session(ProtocolConfig::default());
    let log = send(&mut p, "G4 S5\n");
    assert_eq!(
        log,
        [
            (2.0, "echo:busy: processing".to_string()),
            (4.0, "echo:busy: processing".to_string()),
            (5.0, "ok".to_string())
        ]
    );
    // Exactly two seconds: the command ends before the keepalive is due.
    assert_eq!(texts(&send(&mut p, "G4 S2\n")), ["ok"]);
    // Short commands: no keepalive however many there are.
    let log = send(&mut p, &"G1 X1\n".repeat(10));
    assert_eq!(p.stats().busy, 2);
    assert_eq!(log.len(), 10);
}

#[test]
fn busy_interleaves_with_device_lines_by_time() {
    let mut p = session(ProtocolConfig::default());
    send(&mut p, "G4 S0.5\n");
    let log = send(&mut p, "M109 S200\n");
    let want = [
        (1.5, " T:160.00 /200.00"),
        (2.5, " T:170.00 /200.00"),
        (2.5, "echo:busy: processing"),
        (3.5, " T:180.00 /200.00"),
        (4.5, " T:190.00 /200.00"),
        (4.5, "echo:busy: processing"),
        (5.5, " T:200.00 /200.00"),
        (5.5, "ok"),
    ];
    let want: Log = want.iter().map(|(t, l)| (*t, l.to_string())).collect();
    assert_eq!(log, want);
}

#[test]
fn m113_sets_and_reports_the_keepalive() {
    let mut p = session(ProtocolConfig::default());
    assert_eq!(texts(&send(&mut p, "M113\n")), ["echo:M113 S2", "ok"]);
    send(&mut p, "M113 S1\n");
    let log = send(&mut p, "G4 S3\n");
    assert_eq!(texts(&log), ["echo:busy: processing", "echo:busy: processing", "ok"]);
    send(&mut p, "M113 S0\n");
    assert_eq!(texts(&send(&mut p, "G4 S30\n")), ["ok"]);
    send(&mut p, "M113 S200\n");
    assert_eq!(p.config().keepalive_s, MAX_KEEPALIVE_S);
    assert_eq!(p.device().ran, ["G4 S3", "G4 S30"]);
}

#[test]
fn a_halted_device_is_still_answered() {
    let mut p = session(ProtocolConfig::default());
    let log = send(&mut p, "G28\nM112\n");
    assert_eq!(texts(&log), ["ok", "Error:Printer halted. kill() called!", "ok"]);
    assert!(p.is_halted());
    send(&mut p, "M999\n");
    assert!(!p.is_halted());
    assert_eq!(p.device().ran, ["G28", "M112", "M999"]);
}

#[test]
fn a_device_may_send_its_own_ok() {
    let mut p = session(ProtocolConfig::default());
    let log = send(&mut p, "M105\nG28\n");
    assert_eq!(texts(&log), ["ok T:20.00 /0.00", "ok"]);
}

#[test]
fn the_device_gets_the_bare_command() {
    assert_eq!(command_body(b"N12 G1 X1 *99"), b"G1 X1");
    assert_eq!(command_body(b"N-1 M110 N-1*97"), b"M110 N-1");
    assert_eq!(command_body(b"G1 X1*5"), b"G1 X1*5");
    assert_eq!(command_body(b"N7"), b"");
    assert_eq!(command_body(b"N7*3"), b"");
}

#[test]
fn strtol_reads_like_c() {
    assert_eq!(strtol(b" 42abc"), 42);
    assert_eq!(strtol(b"-7"), -7);
    assert_eq!(strtol(b"+3"), 3);
    assert_eq!(strtol(b"x"), 0);
    assert_eq!(strtol(b"99999999999999999999999"), i64::MAX);
}

proptest! {
    /// However the transport splits the bytes, the replies are the same.
    #[test]
    fn chunking_does_not_matter(cuts in proptest::collection::vec(0usize..200, 0..12)) {
        let mut stream = framed(1, &["G28", "G1 X1 Y2", "M105", "G4 S3", "G1 X5"]);
        stream.push_str("N9 G1 X1*3\nN6 G1*99\n; note\nM114\n");
        let whole = send(&mut session(ProtocolConfig::default()), &stream);
        let mut p = session(ProtocolConfig::default());
        let mut cuts: Vec<usize> = cuts.into_iter().map(|c| c.min(stream.len())).collect();
        cuts.sort_unstable();
        let mut log = Log::new();
        let mut from = 0;
        for cut in cuts.into_iter().chain([stream.len()]) {
            p.feed(&stream.as_bytes()[from..cut], &mut |t, l| log.push((t, l.to_string())));
            from = cut;
        }
        prop_assert_eq!(log, whole);
    }

    /// The firmware's checksum agrees with the core lexer's on every framed line.
    #[test]
    fn agrees_with_the_core_lexer(
        n in 1i64..100_000,
        x in -500.0f64..500.0,
        flip in proptest::option::of(0usize..40),
    ) {
        let mut line = frame_line(n, &format!("G1 X{x:.3} F1800")).into_bytes();
        if let Some(i) = flip {
            let i = i % line.len();
            if line[i].is_ascii_digit() {
                line[i] = if line[i] == b'9' { b'0' } else { line[i] + 1 };
            }
        }
        let mut block = Block::default();
        parse_into(&line, &mut block);
        let lexer_ok = block.checksum.is_some_and(|c| c.is_valid());
        prop_assert_eq!(checksum_verdict(&line).is_none(), lexer_ok);
    }
}

/// `M109` over the protocol with the real interpreter: Marlin 2.x's status line every simulated
/// second, ` T:<reading> /<target> B:.. /.. @:<power> B@:.. W:<residency left or ?>`, with the
/// busy keepalive every 2 s, and `ok` when the residency has run out.
#[test]
fn m109_over_serial_prints_status_with_residency_countdown() {
    let machine = crate::interp::Machine::new(Default::default()).unwrap();
    let mut p = Protocol::new(machine, ProtocolConfig::default());
    let mut log = Log::new();
    p.feed(framed(1, &["M109 S200"]).as_bytes(), &mut |t, l| log.push((t, l.to_string())));
    assert_eq!(log.last().unwrap().1, "ok");
    let (status, other): (Log, Log) =
        log[..log.len() - 1].iter().cloned().partition(|(_, l)| l.starts_with(" T:"));
    // Keepalives every 2 s and nothing else.
    assert!(other.iter().all(|(_, l)| l == "echo:busy: processing"), "{other:?}");
    for (k, (t, _)) in other.iter().enumerate() {
        assert!((t - 2.0 * (k + 1) as f64).abs() < 1e-9, "{other:?}");
    }
    let mut w = Vec::new();
    for (k, (t, line)) in status.iter().enumerate() {
        assert!((t - (k + 1) as f64).abs() < 1e-9, "{t} {line}");
        let words: Vec<&str> = line.split_whitespace().collect();
        assert_eq!(words.len(), 7, "{line}");
        let reading: f64 = words[0].strip_prefix("T:").unwrap().parse().unwrap();
        assert!(reading > 20.0 && reading < 205.0, "{line}");
        assert_eq!(&words[1..4], ["/200.00", "B:25.00", "/0.00"], "{line}");
        let power: u8 = words[4].strip_prefix("@:").unwrap().parse().unwrap();
        assert!(power <= 127, "{line}");
        assert_eq!(words[5], "B@:0", "{line}");
        w.push(words[6].strip_prefix("W:").unwrap().to_owned());
    }
    // `?` while heating (about 74 s from 25 C), then 10 s of residency counted down to 0.
    let first = w.iter().position(|x| x != "?").unwrap();
    assert!((70..80).contains(&first), "{w:?}");
    let counted: Vec<u64> = w[first..].iter().map(|x| x.parse().unwrap()).collect();
    assert_eq!(counted, (0..counted.len() as u64).rev().collect::<Vec<_>>(), "{w:?}");
    assert!((9..=10).contains(&counted.len()), "{w:?}");
}

/// Regression (the previous session's note: gweave's firmware, whose emergency parser reads
/// each byte in its receive interrupt, stopped at an `M112` the queue then refused, and serve
/// did not): an `M112` too long for the queue, or whose checksum the line noise broke, stops
/// the board all the same, as Marlin's `e_parser.h` reads bytes before the queue judges the
/// line; the queue's refusal still follows. On the virtual printer's Marlin model and on the
/// controller core alike.
#[test]
fn an_m112_the_queue_refuses_still_stops_the_board() {
    let long = format!("M112 {}\n", "X".repeat(MAX_LINE_BYTES));
    let broken = "N1 M112*0\n";
    let marlin = || crate::interp::Machine::new(Default::default()).unwrap();
    let core = || {
        let profile = crate::profile::builtin::find("gweave-ramps").unwrap().profile().unwrap();
        crate::core_board::CoreDevice::new(&profile, Vec::new()).unwrap()
    };
    for bytes in [long.as_str(), broken] {
        let mut p = Protocol::new(marlin(), ProtocolConfig::default());
        let mut log = Log::new();
        p.feed(bytes.as_bytes(), &mut |t, l| log.push((t, l.to_string())));
        let replies = texts(&log);
        assert_eq!(replies[0], crate::thermal::protection::KILL_LINE, "{bytes:?}: {replies:?}");
        assert!(replies[1].starts_with("Error:"), "{replies:?}");
        assert!(p.device().report().halted, "{bytes:?}");
        let mut p = Protocol::new(core(), ProtocolConfig::default());
        let mut log = Log::new();
        p.feed(bytes.as_bytes(), &mut |t, l| log.push((t, l.to_string())));
        assert!(texts(&log).iter().any(|l| l.contains("kill() called")), "{bytes:?}: {log:?}");
        assert!(p.device().report("gweave-ramps").halted, "{bytes:?}");
    }
}

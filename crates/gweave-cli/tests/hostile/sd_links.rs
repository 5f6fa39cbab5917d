//! The virtual printer's SD card (`gweave serve --sd DIR`) is a folder of the host computer,
//! where a name can be a link to a file outside it. The card never follows one: a host's
//! `M28`/`M29` upload, `M928` log, `M23` select, `M30` delete and `M20` list reach only the
//! card's own files.

use std::fs;
use std::io::Write;
use std::os::unix::fs::symlink;
use std::path::Path;

use gweave_sim::test_support::{connect, lines_through};

use crate::serve::Server;

const VICTIM: &str = "M117 the user's own file, outside the card\n";

/// A card folder `card/` beside `outside/victim.gco` and `outside/shared.gco`, with
/// `card/LINK.GCO -> ../outside/victim.gco` and `card/SHARED.GCO` a hard link of
/// `outside/shared.gco`.
fn card_with_links(dir: &Path) {
    fs::create_dir(dir.join("card")).unwrap();
    fs::create_dir(dir.join("outside")).unwrap();
    fs::write(dir.join("outside/victim.gco"), VICTIM).unwrap();
    fs::write(dir.join("outside/shared.gco"), VICTIM).unwrap();
    symlink("../outside/victim.gco", dir.join("card/LINK.GCO")).unwrap();
    fs::hard_link(dir.join("outside/shared.gco"), dir.join("card/SHARED.GCO")).unwrap();
}

/// The host's lines, one by one, each with the replies up to its `ok`.
fn talk(addr: std::net::SocketAddr, lines: &[&str]) -> Vec<String> {
    let (mut host, mut reader) = connect(addr);
    lines_through(&mut reader, "echo:Machine");
    let mut got = Vec::new();
    for line in lines {
        host.write_all(format!("{line}\n").as_bytes()).unwrap();
        got.extend(lines_through(&mut reader, "ok"));
    }
    got
}

/// Regression: with `sd/LINK.GCO -> ../outside/victim.gco` in place, `M28 link.gco` ... `M29`
/// overwrote the file outside the card (M20 hid the link and M23 refused it, but the upload
/// opened the name with `File::create`, which follows links).
#[test]
fn sd_card_uploads_never_write_through_a_link() {
    let dir = tempfile::tempdir().unwrap();
    card_with_links(dir.path());
    let (server, addr) = Server::tcp(dir.path(), &["--sd", "card"]);
    let got = talk(
        addr,
        &[
            "M21",
            "M28 link.gco",
            "G92 E0",
            "M29",
            "M928 link.gco",
            "M28 shared.gco",
            "G1 X5",
            "M29",
            "M23 link.gco",
            "M30 link.gco",
            "M20",
        ],
    );
    server.stop().assert_ok();
    let replies = got.iter().filter(|l| *l != "ok").map(String::as_str).collect::<Vec<_>>();
    assert_eq!(
        replies,
        [
            "echo:SD card ok",
            "echo:open failed, File: link.gco.",
            // Without an open upload, G92 runs and M29 closes nothing.
            "echo:open failed, File: link.gco.",
            "Writing to file: shared.gco",
            "Done saving file.",
            "echo:open failed, File: link.gco.",
            "Deletion failed, File: link.gco.",
            "Begin file list",
            "SHARED.GCO 6",
            "End file list",
        ],
        "{got:?}"
    );
    let outside = |name: &str| fs::read_to_string(dir.path().join("outside").join(name)).unwrap();
    assert_eq!(outside("victim.gco"), VICTIM, "written through the symbolic link");
    assert_eq!(outside("shared.gco"), VICTIM, "written through the hard link");
    // The upload is the card's own file now; the link is still the user's.
    assert_eq!(fs::read_to_string(dir.path().join("card/SHARED.GCO")).unwrap(), "G1 X5\n");
    assert!(fs::symlink_metadata(dir.path().join("card/LINK.GCO")).unwrap().file_type().is_symlink());
}

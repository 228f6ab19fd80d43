//! Every writer against a full filesystem: a 64 KiB tmpfs, filled, holding an old copy of the
//! output. Each command must end in bounded time with exit 2 and a message that names the file
//! and the reason, leave the old file intact and leave no temp file (`.NAME.PID.N.tmp`) or
//! sweep journal (`NAME.partial.csv`) behind.
//!
//! The tmpfs is mounted in a private user and mount namespace (`unshare -rm`), so the test
//! needs neither root nor a change to the machine; where that is not allowed (some containers),
//! the test says so and checks nothing.

use std::path::{Path, PathBuf};
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_latticesim");

/// Run by `unshare -rm bash -c SCRIPT _ NAME COMMAND...`: mounts a 64 KiB tmpfs on a new
/// directory, writes `old` to NAME in it, fills it, runs COMMAND with every `@D@` replaced by
/// the directory (at most 60 s), then prints the exit status, the command's stderr, the files
/// left and the old file's content, each after a marker line.
const SCRIPT: &str = r#"
set -u
name=$1; shift
D=$(mktemp -d)
if ! mount -t tmpfs -o size=64k tmpfs "$D" 2>/dev/null; then echo "@@no-tmpfs"; exit 0; fi
printf 'old\n' > "$D/$name"
dd if=/dev/zero of="$D/filler" bs=4k 2>/dev/null
args=("${@//@D@/$D}")
err=$(timeout 60 "${args[@]}" 2>&1 >/dev/null)
echo "@@exit $?"
echo "@@stderr"; printf '%s\n' "$err"
echo "@@files"; ls -A "$D"
echo "@@old"; cat "$D/$name"
"#;

/// Run as `bash -c VIEWER_SAVE _ DIR BIN ROOT NAME`: starts `latticesim serve` on the
/// gravity example in DIR, saves NAME through the viewer's file API, stops the server, and
/// prints the answer's body on stderr; exit 0 for 200, else 2.
const VIEWER_SAVE: &str = r#"
set -u
D=$1; BIN=$2; R=$3; name=$4
cd "$D"
exec 3< <(exec "$BIN" serve "$R/examples/gravity/rules.txt" "$R/examples/gravity/agents.txt" --port 0 2>&1)
pid=$!
read -r -t 20 line <&3
url=$(grep -o 'http://[^ ]*' <<<"$line")
base=${url%%\?*}
token=${url#*token=}
out=$(curl -s -m 20 -w '\n%{http_code}' -H "X-Latticesim-Token: $token" \
  -H 'Content-Type: application/json' \
  --data '{"path":"'"$name"'","text":"new text\n"}' "${base%/}/api/file")
kill "$pid" 2>/dev/null
code=${out##*$'\n'}
printf '%s\n' "${out%$'\n'*}" >&2
[ "$code" = 200 ] && exit 0 || exit 2
"#;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn scratch() -> PathBuf {
    let d = std::env::temp_dir().join(format!("latticesim-full-disk-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs the command `cmd` (with `@D@` for the full directory) so that it writes `name`
/// there; `None` where no private tmpfs can be mounted.
fn on_full_disk(name: &str, cmd: &[&str]) -> Option<String> {
    let out = Command::new("unshare")
        .arg("-rm")
        .args(["bash", "-c", SCRIPT, "_", name])
        .args(cmd)
        .current_dir(root())
        .output()
        .ok()?;
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    if !out.status.success() || text.contains("@@no-tmpfs") {
        eprintln!(
            "skipped: no private tmpfs here (unshare -rm: {})",
            String::from_utf8_lossy(&out.stderr).trim()
        );
        return None;
    }
    Some(text)
}

/// The text between `@@marker` and the next marker line.
fn section<'a>(text: &'a str, marker: &str) -> &'a str {
    let start = text
        .find(marker)
        .map(|i| i + marker.len())
        .unwrap_or(text.len());
    let rest = &text[start..];
    rest.find("\n@@").map_or(rest, |end| &rest[..end]).trim()
}

/// `latticesim ARGS` writing `name` on a full disk fails cleanly (false where it cannot be
/// tried).
fn check(name: &str, args: &[&str]) -> bool {
    check_command(name, &[&[BIN], args].concat())
}

/// The command `cmd` writing `name` on a full disk fails cleanly.
fn check_command(name: &str, cmd: &[&str]) -> bool {
    let Some(text) = on_full_disk(name, cmd) else {
        return false;
    };
    let what = format!("{name} by {cmd:?}:\n{text}");
    assert_eq!(section(&text, "@@exit"), "2", "{what}");
    let stderr = section(&text, "@@stderr");
    assert!(
        stderr.contains("cannot write") && stderr.contains("No space left on device"),
        "{what}"
    );
    assert!(stderr.contains(name), "the message names the file: {what}");
    assert!(!stderr.contains("panicked"), "{what}");
    let mut files: Vec<&str> = section(&text, "@@files").lines().collect();
    files.sort_unstable();
    let mut want = ["filler", name];
    want.sort_unstable();
    assert_eq!(files, want, "nothing else is left: {what}");
    assert_eq!(
        section(&text, "@@old"),
        "old",
        "the old file is intact: {what}"
    );
    true
}

const GRAVITY: [&str; 2] = ["examples/gravity/rules.txt", "examples/gravity/agents.txt"];

#[test]
fn every_writer_on_a_full_disk_fails_cleanly() {
    let s = scratch();
    let big = s.join("cloud.txt");
    let big = big.to_str().unwrap();
    let made = Command::new(BIN)
        .args([
            "gen", "cloud", "--n", "100000", "--width", "400", "--height", "400",
        ])
        .args(["--out", big])
        .output()
        .unwrap();
    assert!(
        made.status.success(),
        "{}",
        String::from_utf8_lossy(&made.stderr)
    );
    let part = s.join("part.csv");
    let part = part.to_str().unwrap();
    let swept = Command::new(BIN)
        .current_dir(root())
        .args(["sweep", "examples/gravity/rules.txt", "--shape", "line"])
        .args(["--sizes", "4,8", "--out", part])
        .output()
        .unwrap();
    assert!(
        swept.status.success(),
        "{}",
        String::from_utf8_lossy(&swept.stderr)
    );
    let side = s.join("side.csv");
    let side = side.to_str().unwrap();

    // Each case: the file it writes in the full folder, then its arguments.
    let run = ["run", GRAVITY[0], GRAVITY[1]];
    let sweep = ["sweep", GRAVITY[0], "--shape", "line", "--sizes", "4,8"];
    let cases: Vec<(&str, Vec<&str>)> = vec![
        ("a.txt", [&run[..], &["--out", "@D@/a.txt"]].concat()),
        (
            "a.ckpt",
            [&run[..], &["--checkpoint", "@D@/a.ckpt"]].concat(),
        ),
        ("a.csv", [&run[..], &["--series", "@D@/a.csv"]].concat()),
        ("a.trace", [&run[..], &["--trace", "@D@/a.trace"]].concat()),
        ("a.json", [&run[..], &["--stats", "@D@/a.json"]].concat()),
        (
            "big.txt",
            vec![
                "run",
                GRAVITY[0],
                big,
                "--max-steps",
                "1",
                "--threads",
                "2",
                "--out",
                "@D@/big.txt",
            ],
        ),
        ("t.csv", [&sweep[..], &["--out", "@D@/t.csv"]].concat()),
        (
            "t.parquet",
            [&sweep[..], &["--out", "@D@/t.parquet"]].concat(),
        ),
        (
            "p.png",
            [&sweep[..], &["--out", side, "--plot", "@D@/p.png"]].concat(),
        ),
        ("m.csv", vec!["merge", part, "--out", "@D@/m.csv"]),
        (
            "g.txt",
            vec![
                "gen",
                "cloud",
                "--n",
                "20000",
                "--width",
                "300",
                "--height",
                "300",
                "--out",
                "@D@/g.txt",
            ],
        ),
        (
            "r.png",
            [&["render"], &run[1..], &["--out", "@D@/r.png"]].concat(),
        ),
        (
            "r.gif",
            [
                &["render"],
                &run[1..],
                &["--steps", "0..20", "--out", "@D@/r.gif"],
            ]
            .concat(),
        ),
    ];
    let mut checked = 0;
    for (name, args) in &cases {
        if !check(name, args) {
            break;
        }
        checked += 1;
    }
    // The viewer's save: `POST /api/file` with a text, to a server whose working folder
    // is the full one; the answer's error is the message (exit 2 for any status but 200).
    if checked == cases.len()
        && check_command(
            "v.txt",
            &[
                "bash",
                "-c",
                VIEWER_SAVE,
                "_",
                "@D@",
                BIN,
                root().to_str().unwrap(),
                "v.txt",
            ],
        )
    {
        checked += 1;
    }
    eprintln!(
        "{checked} of {} writers checked on a full disk",
        cases.len() + 1
    );
    let _ = std::fs::remove_dir_all(&s);
}

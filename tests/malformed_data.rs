//! A corpus of malformed datasets and CSV/npz data files, generated in a temporary directory.
//! Every case must be refused with a message that names the file and the field (array,
//! column, line or key) that is wrong.

mod common;
use occam::data::DataSource;
use occam::data::dataset::{Dataset, ExperimentData};
use std::collections::BTreeMap;
use std::io::Write as _;

/// A small valid dataset: experiment `inv1`, 64 samples at 10 Hz, 32 noise samples, an extra
/// channel `g1` with a noise series.
fn dataset() -> Dataset {
    let v = |a: f64, n: usize| (0..n).map(|k| a * (k as f64 + 1.0)).collect::<Vec<_>>();
    let mut e = ExperimentData::new(
        "inv1",
        10.0,
        [v(1.0, 64), v(2.0, 64)],
        [v(3.0, 64), v(4.0, 64)],
        [v(5.0, 32), v(6.0, 32)],
    );
    e.extra.insert("g1".into(), v(0.5, 64));
    e.noise_extra.insert("g1".into(), v(0.25, 32));
    Dataset {
        experiments: vec![e],
        seed: Some(3),
        truth: Some(Default::default()),
        extra: serde_json::Value::Null,
    }
}

/// `.npy` bytes with header dictionary `h` (padded as numpy pads it) and `data`.
fn npy(h: &str, data: &[u8]) -> Vec<u8> {
    let mut h = h.to_string();
    while !(10 + h.len() + 1).is_multiple_of(64) {
        h.push(' ');
    }
    h.push('\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend((h.len() as u16).to_le_bytes());
    out.extend(h.as_bytes());
    out.extend(data);
    out
}

fn f8(v: &[f64]) -> Vec<u8> {
    let h = format!(
        "{{'descr': '<f8', 'fortran_order': False, 'shape': ({},), }}",
        v.len()
    );
    npy(
        &h,
        &v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<_>>(),
    )
}

/// An npz archive of the given `.npy` entries (names without `.npy`).
fn zip(entries: &[(String, Vec<u8>)]) -> Vec<u8> {
    let mut z = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let o =
        zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Stored);
    for (n, b) in entries {
        z.start_file(format!("{n}.npy"), o).unwrap();
        z.write_all(b).unwrap();
    }
    z.finish().unwrap().into_inner()
}

/// The arrays of `dataset()` as npz entries, with `edit` applied.
fn arrays(edit: impl Fn(&mut BTreeMap<String, Vec<u8>>)) -> Vec<u8> {
    let d = dataset();
    let e = &d.experiments[0];
    let mut m: BTreeMap<String, Vec<u8>> = BTreeMap::new();
    for (n, v) in [
        ("o1", &e.o[0]),
        ("o12", &e.o[1]),
        ("i1", &e.i[0]),
        ("i12", &e.i[1]),
        ("noise_o1", &e.noise[0]),
        ("noise_o12", &e.noise[1]),
        ("g1", &e.extra["g1"]),
        ("noise_g1", &e.noise_extra["g1"]),
    ] {
        m.insert(format!("inv1.{n}"), f8(v));
    }
    m.insert("inv1.fs".into(), f8(&[10.0]));
    m.insert("truth".into(), f8(d.truth.unwrap().to_array().as_ref()));
    edit(&mut m);
    zip(&m.into_iter().collect::<Vec<_>>())
}

/// How a case breaks a dataset directory holding a valid pair.
enum Break {
    /// Edit the sidecar's JSON value.
    Json(fn(&mut serde_json::Value)),
    /// Replace the sidecar's text.
    JsonText(&'static str),
    /// Replace the archive (the sidecar loses its digest, as an old-format pair).
    Npz(fn() -> Vec<u8>),
    /// Replace the archive, keeping the sidecar's digest.
    NpzKeepDigest(fn() -> Vec<u8>),
    /// Damage the archive's bytes (old-format sidecar).
    NpzBytes(fn(&mut Vec<u8>)),
    /// Remove a file.
    Remove(&'static str),
}

struct DatasetCase {
    name: &'static str,
    brk: Break,
    /// The file the message must name.
    file: &'static str,
    /// Strings the message must contain (the field and what is wrong).
    want: &'static [&'static str],
}

fn run_dataset_case(c: &DatasetCase) -> String {
    let dir = tempfile::tempdir().unwrap();
    let (npz, json) = dataset().write(dir.path()).unwrap();
    let mut side: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let strip = |side: &mut serde_json::Value| {
        side.as_object_mut().unwrap().remove("npz_digest");
        std::fs::write(&json, serde_json::to_string_pretty(side).unwrap()).unwrap();
    };
    match &c.brk {
        Break::Json(f) => {
            f(&mut side);
            std::fs::write(&json, serde_json::to_string_pretty(&side).unwrap()).unwrap();
        }
        Break::JsonText(t) => std::fs::write(&json, t).unwrap(),
        Break::Npz(f) => {
            strip(&mut side);
            std::fs::write(&npz, f()).unwrap();
        }
        Break::NpzKeepDigest(f) => std::fs::write(&npz, f()).unwrap(),
        Break::NpzBytes(f) => {
            strip(&mut side);
            let mut b = std::fs::read(&npz).unwrap();
            f(&mut b);
            std::fs::write(&npz, b).unwrap();
        }
        Break::Remove(f) => std::fs::remove_file(dir.path().join(f)).unwrap(),
    }
    match Dataset::read(dir.path()) {
        Ok(_) => panic!("{}: accepted", c.name),
        Err(e) => {
            let msg = e.to_string();
            common::readable(&msg).unwrap_or_else(|why| panic!("{}: {why}: {msg}", c.name));
            msg
        }
    }
}

fn dataset_cases() -> Vec<DatasetCase> {
    use Break::*;
    vec![
        DatasetCase {
            name: "json: wrong sample rate",
            brk: Json(|v| v["experiments"][0]["fs"] = 20.0.into()),
            file: "dataset.json",
            want: &["dataset.npz", "fs = 20 Hz", "inv1.fs"],
        },
        DatasetCase {
            name: "json: negative sample rate",
            brk: Json(|v| v["experiments"][0]["fs"] = (-1.0).into()),
            file: "dataset.json",
            want: &["fs = -1 Hz", "inv1.fs"],
        },
        DatasetCase {
            name: "json: sample rate 1e308",
            brk: Json(|v| v["experiments"][0]["fs"] = 1e308.into()),
            file: "dataset.json",
            want: &["fs = 1", "inv1.fs"],
        },
        DatasetCase {
            name: "json: wrong length",
            brk: Json(|v| v["experiments"][0]["n_samples"] = 60.into()),
            file: "dataset.json",
            want: &["dataset.npz", "n_samples = 60", "64 samples"],
        },
        DatasetCase {
            name: "json: huge length",
            brk: Json(|v| v["experiments"][0]["n_samples"] = u64::MAX.into()),
            file: "dataset.json",
            want: &["n_samples = 18446744073709551615"],
        },
        DatasetCase {
            name: "json: length as a float",
            brk: Json(|v| v["experiments"][0]["n_samples"] = 1e300.into()),
            file: "dataset.json",
            want: &["(at `n_samples`)"],
        },
        DatasetCase {
            name: "json: wrong noise length",
            brk: Json(|v| v["experiments"][0]["n_noise_samples"] = 31.into()),
            file: "dataset.json",
            want: &["n_noise_samples = 31", "inv1.noise_"],
        },
        DatasetCase {
            name: "json: renamed experiment",
            brk: Json(|v| v["experiments"][0]["name"] = "inv2".into()),
            file: "dataset.json",
            want: &["dataset.npz", "inv2."],
        },
        DatasetCase {
            name: "json: experiment listed twice",
            brk: Json(|v| {
                let e = v["experiments"][0].clone();
                v["experiments"].as_array_mut().unwrap().push(e);
            }),
            file: "dataset.json",
            want: &["experiment `inv1` is listed twice"],
        },
        DatasetCase {
            name: "json: experiments missing",
            brk: Json(|v| v["experiments"].as_array_mut().unwrap().clear()),
            file: "dataset.json",
            want: &["dataset.npz", "experiment `inv1`"],
        },
        DatasetCase {
            name: "json: channel not listed",
            brk: Json(|v| v["experiments"][0]["channels"] = serde_json::json!([])),
            file: "dataset.json",
            want: &["dataset.npz", "inv1.g1"],
        },
        DatasetCase {
            name: "json: channel the archive lacks",
            brk: Json(|v| v["experiments"][0]["channels"] = serde_json::json!(["g1", "g7"])),
            file: "dataset.json",
            want: &["dataset.npz", "inv1.g7"],
        },
        DatasetCase {
            name: "json: truth differs",
            brk: Json(|v| v["truth"]["d21"] = 2.5.into()),
            file: "dataset.json",
            want: &["dataset.npz", "truth"],
        },
        DatasetCase {
            name: "json: not JSON",
            brk: JsonText("{\"occam_version\": \"0.1.0\", "),
            file: "dataset.json",
            want: &["not an occam dataset sidecar"],
        },
        DatasetCase {
            name: "json: field of the wrong type",
            brk: Json(|v| v["experiments"][0]["fs"] = "ten".into()),
            file: "dataset.json",
            want: &["(at `fs`)"],
        },
        DatasetCase {
            name: "json: malformed digest",
            brk: Json(|v| v["npz_digest"]["bytes"] = (-5).into()),
            file: "dataset.json",
            want: &["(at `bytes`)"],
        },
        DatasetCase {
            name: "torn pair: another run's archive",
            brk: NpzKeepDigest(|| {
                arrays(|m| {
                    m.insert("inv1.o1".into(), f8(&[7.0; 64]));
                })
            }),
            file: "dataset.npz",
            want: &[
                "does not match",
                "dataset.json",
                "written by a different run",
                "rerun `occam simulate`",
            ],
        },
        DatasetCase {
            name: "npz: a channel shorter than the others",
            brk: Npz(|| {
                arrays(|m| {
                    m.insert("inv1.o12".into(), f8(&[1.0; 63]));
                })
            }),
            file: "dataset.npz",
            want: &["inv1.o12", "63 samples", "n_samples = 64"],
        },
        DatasetCase {
            name: "npz: noise stretch of another length",
            brk: Npz(|| {
                arrays(|m| {
                    m.insert("inv1.noise_g1".into(), f8(&[1.0; 40]));
                })
            }),
            file: "dataset.npz",
            want: &["inv1.noise_g1", "40 samples", "n_noise_samples = 32"],
        },
        DatasetCase {
            name: "npz: NaN sample",
            brk: Npz(|| {
                arrays(|m| {
                    let mut v = vec![1.0; 64];
                    v[3] = f64::NAN;
                    m.insert("inv1.o1".into(), f8(&v));
                })
            }),
            file: "dataset.npz",
            want: &["sidecar lists gaps []", "NaN samples make them [[3, 4]]"],
        },
        DatasetCase {
            name: "npz: infinite noise sample",
            brk: Npz(|| {
                arrays(|m| {
                    let mut v = vec![1.0; 32];
                    v[31] = f64::NEG_INFINITY;
                    m.insert("inv1.noise_o12".into(), f8(&v));
                })
            }),
            file: "dataset.npz",
            want: &["`noise_o12` sample 31 is -inf"],
        },
        DatasetCase {
            name: "npz: float32 array",
            brk: Npz(|| {
                arrays(|m| {
                    m.insert(
                        "inv1.i1".into(),
                        npy(
                            "{'descr': '<f4', 'fortran_order': False, 'shape': (64,), }",
                            &[0; 256],
                        ),
                    );
                })
            }),
            file: "dataset.npz",
            want: &["array `inv1.i1`", "dtype `<f4`", "float64"],
        },
        DatasetCase {
            name: "npz: 2-D array",
            brk: Npz(|| {
                arrays(|m| {
                    m.insert(
                        "inv1.i12".into(),
                        npy(
                            "{'descr': '<f8', 'fortran_order': False, 'shape': (8, 8), }",
                            &[0; 512],
                        ),
                    );
                })
            }),
            file: "dataset.npz",
            want: &["array `inv1.i12`", "1-D"],
        },
        DatasetCase {
            name: "npz: header claims 10^18 samples",
            brk: Npz(|| {
                arrays(|m| {
                    m.insert(
                    "inv1.o1".into(),
                    npy(
                        "{'descr': '<f8', 'fortran_order': False, 'shape': (1000000000000000000,), }",
                        &[0; 512],
                    ),
                );
                })
            }),
            file: "dataset.npz",
            want: &[
                "array `inv1.o1`",
                "1000000000000000000 samples",
                "512 bytes",
            ],
        },
        DatasetCase {
            name: "npz: array data truncated",
            brk: Npz(|| {
                arrays(|m| {
                    let b = m.get_mut("inv1.g1").unwrap();
                    b.truncate(b.len() - 3);
                })
            }),
            file: "dataset.npz",
            want: &["array `inv1.g1`", "truncated or damaged"],
        },
        DatasetCase {
            name: "npz: header damaged",
            brk: Npz(|| {
                arrays(|m| {
                    m.insert(
                        "inv1.fs".into(),
                        npy(
                            "{'descr': '<f8', 'fortran_order': False, 'shape': (1,, }",
                            &[0; 8],
                        ),
                    );
                })
            }),
            file: "dataset.npz",
            want: &["array `inv1.fs`", "malformed header", "shape"],
        },
        DatasetCase {
            name: "npz: sample rate array of two values",
            brk: Npz(|| {
                arrays(|m| {
                    m.insert("inv1.fs".into(), f8(&[10.0, 10.0]));
                })
            }),
            file: "dataset.npz",
            want: &["inv1.fs", "fs = 10 Hz"],
        },
        DatasetCase {
            name: "npz: all arrays empty",
            brk: Npz(|| {
                arrays(|m| {
                    for (k, v) in m.iter_mut() {
                        if k.starts_with("inv1.") && k != "inv1.fs" {
                            *v = f8(&[]);
                        }
                    }
                })
            }),
            file: "dataset.npz",
            want: &["inv1.g1", "0 samples"],
        },
        DatasetCase {
            name: "npz: an array the sidecar does not list",
            brk: Npz(|| {
                arrays(|m| {
                    m.insert("inv1.x".into(), f8(&[1.0; 64]));
                })
            }),
            file: "dataset.npz",
            want: &["dataset.json", "inv1.x"],
        },
        DatasetCase {
            name: "npz: an array missing",
            brk: Npz(|| {
                arrays(|m| {
                    m.remove("inv1.i12");
                })
            }),
            file: "dataset.npz",
            want: &["dataset.json", "inv1.i12"],
        },
        DatasetCase {
            name: "npz: not a zip archive",
            brk: NpzBytes(|b| b.truncate(100)),
            file: "dataset.npz",
            want: &["not a readable npz (zip) archive"],
        },
        DatasetCase {
            name: "npz: directory claims a 4 GB entry",
            brk: NpzBytes(|b| {
                // the first central-directory record's uncompressed size (offset 24)
                let cd = b.windows(4).position(|w| w == b"PK\x01\x02").unwrap();
                b[cd + 24..cd + 28].copy_from_slice(&0xFFFF_FFF0u32.to_le_bytes());
            }),
            file: "dataset.npz",
            want: &["array `inv1.o1`", "4294967280 bytes", "damaged"],
        },
        DatasetCase {
            name: "npz: a flipped bit (stored CRC-32 does not match)",
            brk: NpzBytes(|b| {
                // 61.0 occurs only in inv1.o1; its lowest mantissa byte changes the value by
                // an ulp, which parses as a number: only the CRC tells
                let at = b.windows(8).position(|w| w == 61f64.to_le_bytes()).unwrap();
                b[at] ^= 1;
            }),
            file: "dataset.npz",
            want: &["array `inv1.o1`", "CRC-32", "rewrite it"],
        },
        DatasetCase {
            name: "missing archive",
            brk: Remove("dataset.npz"),
            file: "dataset.npz",
            want: &["no such file", "dataset.json and dataset.npz"],
        },
        DatasetCase {
            name: "missing sidecar",
            brk: Remove("dataset.json"),
            file: "dataset.json",
            want: &["no such file"],
        },
    ]
}

/// A CSV (or npz) data source case: files to write, the source, the channels requested.
struct SourceCase {
    name: &'static str,
    files: Vec<(&'static str, Vec<u8>)>,
    fs: Option<f64>,
    noise: bool,
    channels: &'static [&'static str],
    file: &'static str,
    want: &'static [&'static str],
}

fn rows(n: usize, dt: f64, f: impl Fn(usize, f64) -> String) -> String {
    (0..n).map(|k| f(k, k as f64 * dt) + "\n").collect()
}

fn good_csv() -> String {
    format!(
        "t,o1,o12\n{}",
        rows(20, 0.1, |k, t| format!("{t},{k},{}", -(k as f64)))
    )
}

fn with_row(k_bad: usize, row: &str) -> Vec<u8> {
    let mut s = String::from("t,o1,o12\n");
    for k in 0..20 {
        if k == k_bad {
            s += row;
        } else {
            s += &format!("{},{k},{k}", 0.1 * k as f64);
        }
        s.push('\n');
    }
    s.into_bytes()
}

fn source_cases() -> Vec<SourceCase> {
    let c = |name, text: Vec<u8>, want| SourceCase {
        name,
        files: vec![("d.csv", text)],
        fs: None,
        noise: false,
        channels: &["o1", "o12"],
        file: "d.csv",
        want,
    };
    let npz_case = |name, bytes: Vec<u8>, want| SourceCase {
        name,
        files: vec![("d.npz", bytes)],
        fs: Some(10.0),
        noise: false,
        channels: &["o1", "o12"],
        file: "d.npz",
        want,
    };
    let mut gap = String::from("t,o1,o12\n");
    for k in 0..20 {
        gap += &format!(
            "{},{k},{k}\n",
            0.1 * k as f64 + if k >= 7 { 0.05 } else { 0.0 }
        );
    }
    vec![
        c(
            "csv: NaN time stamp",
            with_row(2, "nan,1,1"),
            &["line 4, column `t`", "time stamp is missing"],
        ),
        c(
            "csv: infinity",
            with_row(5, "0.5,1,-inf"),
            &["line 7, column `o12`", "not finite"],
        ),
        c(
            "csv: overflowing number",
            with_row(5, "0.5,1e999,1"),
            &["line 7, column `o1`", "not finite"],
        ),
        // issue 51: finite, but its square overflows (the fit failed later, naming no file)
        c(
            "csv: 1e308 in a read-out",
            with_row(5, "0.5,1e308,1"),
            &["line 7, column `o1`", "1e308 is beyond ±1e150"],
        ),
        c(
            "csv: -1e308 in a read-out",
            with_row(5, "0.5,1,-1e308"),
            &["line 7, column `o12`", "-1e308 is beyond ±1e150"],
        ),
        c(
            "csv: not a number",
            with_row(3, "0.3,1,abc"),
            &["line 5, column `o12`", "`abc` is not a number"],
        ),
        c(
            "csv: short row",
            with_row(4, "0.4,1"),
            &["line 6", "2 values for 3 columns"],
        ),
        c(
            "csv: long row",
            with_row(4, "0.4,1,2,3"),
            &["line 6", "4 values for 3 columns"],
        ),
        c(
            "csv: empty time stamp",
            with_row(4, ",1,2"),
            &["line 6, column `t`", "time stamp is missing"],
        ),
        c(
            "csv: quoted decimal comma",
            with_row(6, "0.6,\"1,5\",2"),
            &["line 8", "4 values for 3 columns", "decimal comma"],
        ),
        c(
            "csv: unbalanced quote",
            with_row(6, "0.6,\"1.5,2"),
            &["line 8, column `o1`", "unbalanced"],
        ),
        c(
            "csv: duplicate column",
            b"t,o1,o1\n0,1,2\n".to_vec(),
            &["line 1", "`o1` appears twice", "columns 2 and 3"],
        ),
        c(
            "csv: no header row",
            b"0,1,2\n0.1,2,3\n".to_vec(),
            &["line 1, column 1", "name the columns"],
        ),
        c(
            "csv: unnamed column",
            b"t,,o12\n0,1,2\n".to_vec(),
            &["line 1, column 2", "name the columns"],
        ),
        c("csv: empty file", Vec::new(), &["empty file", "header row"]),
        c(
            "csv: only a header",
            b"t,o1,o12\n".to_vec(),
            &["no data rows", "line 1"],
        ),
        c(
            "csv: time not increasing",
            with_row(9, "0.7,1,1"),
            &["line 11, column `t`", "does not increase"],
        ),
        c(
            "csv: time off the grid",
            gap.into_bytes(),
            &[
                "line 9, column `t`",
                "not a whole number of the series' spacing",
            ],
        ),
        c(
            "csv: old Mac line ends",
            good_csv().replace('\n', "\r").into_bytes(),
            &["line 1", "carriage return"],
        ),
        c(
            "csv: not UTF-8",
            {
                let mut b = good_csv().into_bytes();
                b[30] = 0xff;
                b
            },
            &["line 4", "not UTF-8"],
        ),
        c(
            "csv: a byte-order mark inside",
            with_row(1, "0.1,\u{feff}1,1"),
            &["line 3, column `o1`", "is not a number"],
        ),
        c(
            "csv: missing channel column",
            format!("t,o1\n{}", rows(20, 0.1, |k, t| format!("{t},{k}"))).into_bytes(),
            &["channel `o12`", "no column `o12`", "`t`, `o1`"],
        ),
        c(
            "csv: too short",
            format!("t,o1,o12\n{}", rows(8, 0.1, |k, t| format!("{t},{k},{k}"))).into_bytes(),
            &["experiment `inv1`", "too short", "8 fit samples"],
        ),
        c(
            "csv: one row, no rate",
            b"t,o1,o12\n0,1,1\n".to_vec(),
            &["column `t`", "at least two samples"],
        ),
        SourceCase {
            fs: Some(4.0),
            ..c(
                "csv: fs disagrees with the time column",
                good_csv().into_bytes(),
                &["`t` gives 10", "fs = 4 Hz"],
            )
        },
        SourceCase {
            fs: Some(-3.0),
            ..c(
                "csv: negative fs",
                good_csv().into_bytes(),
                &["fs = -3 Hz", "not > 0"],
            )
        },
        SourceCase {
            files: vec![
                ("d.csv", good_csv().into_bytes()),
                (
                    "n.csv",
                    format!("t,o1,o12\n{}", rows(20, 0.5, |k, t| format!("{t},{k},{k}")))
                        .into_bytes(),
                ),
            ],
            noise: true,
            file: "n.csv",
            ..c(
                "csv: noise file at another rate",
                Vec::new(),
                &["2 Hz", "10 Hz", "d.csv"],
            )
        },
        SourceCase {
            files: vec![
                ("d.csv", good_csv().into_bytes()),
                (
                    "n.csv",
                    format!("t,o1,o12\n{}", rows(10, 0.1, |k, t| format!("{t},{k},{k}")))
                        .into_bytes(),
                ),
            ],
            noise: true,
            file: "n.csv",
            ..c(
                "csv: noise stretch too short",
                Vec::new(),
                &["noise-only stretch of `o1`", "10 samples", "≥ 16"],
            )
        },
        SourceCase {
            files: vec![
                ("d.csv", good_csv().into_bytes()),
                ("n.csv", b"t,o1,o12\n0,1,\n0.1,2,3\n".to_vec()),
            ],
            noise: true,
            file: "n.csv",
            ..c(
                "csv: noise file with an empty cell, too short",
                Vec::new(),
                &["noise-only stretch of `o1`", "2 samples", "≥ 16"],
            )
        },
        npz_case(
            "npz file: arrays of different lengths",
            zip(&[
                ("o1".into(), f8(&[1.0; 64])),
                ("o12".into(), f8(&[1.0; 60])),
            ]),
            &["array `o12` has 60 samples", "`o1` has 64"],
        ),
        npz_case(
            "npz file: missing array",
            zip(&[("o1".into(), f8(&[1.0; 64])), ("x".into(), f8(&[1.0; 64]))]),
            &["channel `o12`", "no array `o12`", "`o1`, `x`"],
        ),
        npz_case(
            "npz file: infinity",
            zip(&[
                ("o1".into(), f8(&[1.0; 64])),
                ("o12".into(), {
                    let mut v = vec![1.0; 64];
                    v[9] = f64::INFINITY;
                    f8(&v)
                }),
            ]),
            &["array `o12`, sample 9", "not finite"],
        ),
        npz_case(
            "npz file: 1e308 in a read-out",
            zip(&[
                ("o1".into(), f8(&[1.0; 64])),
                ("o12".into(), {
                    let mut v = vec![1.0; 64];
                    v[9] = 1e308;
                    f8(&v)
                }),
            ]),
            &["array `o12`, sample 9", "1e308 is beyond ±1e150"],
        ),
        npz_case(
            "npz file: empty array",
            zip(&[("o1".into(), f8(&[])), ("o12".into(), f8(&[]))]),
            &["array `o1` has no samples"],
        ),
        npz_case(
            "npz file: integer array",
            zip(&[
                (
                    "o1".into(),
                    npy(
                        "{'descr': '<i8', 'fortran_order': False, 'shape': (2,), }",
                        &[0; 16],
                    ),
                ),
                ("o12".into(), f8(&[1.0; 64])),
            ]),
            &["array `o1`", "dtype `<i8`", "astype"],
        ),
        npz_case(
            "npz file: header claims 2^60 samples",
            zip(&[
                (
                    "o1".into(),
                    npy(
                        "{'descr': '<f8', 'fortran_order': False, 'shape': (1152921504606846976,), }",
                        &[0; 64],
                    ),
                ),
                ("o12".into(), f8(&[1.0; 64])),
            ]),
            &["array `o1`", "1152921504606846976 samples"],
        ),
        npz_case("npz file: no arrays", zip(&[]), &["empty archive"]),
        npz_case(
            "npz file: not a zip",
            b"PK\x03\x04garbage".to_vec(),
            &["not a readable npz"],
        ),
    ]
}

fn run_source_case(c: &SourceCase) -> String {
    let dir = tempfile::tempdir().unwrap();
    for (n, b) in &c.files {
        std::fs::write(dir.path().join(n), b).unwrap();
    }
    let src = DataSource {
        data: c.files[0].0.into(),
        columns: BTreeMap::new(),
        fs: c.fs,
        noise_data: c.noise.then(|| "n.csv".into()),
        gaps: Vec::new(),
        noise_gaps: Vec::new(),
    };
    let chans: Vec<String> = c.channels.iter().map(|s| s.to_string()).collect();
    match src.load("inv1", dir.path(), &chans) {
        Ok(_) => panic!("{}: accepted", c.name),
        Err(e) => {
            let msg = e.to_string();
            common::readable(&msg).unwrap_or_else(|why| panic!("{}: {why}: {msg}", c.name));
            msg
        }
    }
}

/// Every case is refused with a message naming the file and the field; prints the counts.
#[test]
fn malformed_datasets_and_data_files_are_refused_with_named_fields() {
    let mut failures = Vec::new();
    let (mut n_ds, mut n_src) = (0, 0);
    for c in dataset_cases() {
        let e = run_dataset_case(&c);
        n_ds += 1;
        let missing: Vec<_> = std::iter::once(c.file)
            .chain(c.want.iter().copied())
            .filter(|w| !e.contains(w))
            .collect();
        if !missing.is_empty() {
            failures.push(format!("{}: lacks {missing:?} in: {e}", c.name));
        }
    }
    for c in source_cases() {
        let e = run_source_case(&c);
        n_src += 1;
        let missing: Vec<_> = std::iter::once(c.file)
            .chain(c.want.iter().copied())
            .filter(|w| !e.contains(w))
            .collect();
        if !missing.is_empty() {
            failures.push(format!("{}: lacks {missing:?} in: {e}", c.name));
        }
    }
    eprintln!(
        "malformed data corpus: {n_ds} dataset cases, {n_src} data-file cases, {} failures",
        failures.len()
    );
    assert!(failures.is_empty(), "\n{}", failures.join("\n"));
    assert!(n_ds + n_src >= 60, "{n_ds} + {n_src}");
}

/// The accepted variants: a BOM, CRLF line ends and quoted cells read the same numbers as the
/// plain file.
#[test]
fn bom_crlf_and_quotes_read_the_same_numbers() {
    let dir = tempfile::tempdir().unwrap();
    let plain = good_csv();
    let fancy = format!(
        "\u{feff}{}",
        plain
            .lines()
            .map(|l| l
                .split(',')
                .map(|c| format!("\"{c}\""))
                .collect::<Vec<_>>()
                .join(","))
            .collect::<Vec<_>>()
            .join("\r\n")
    );
    let mut loaded = Vec::new();
    for (n, text) in [("a.csv", plain), ("b.csv", fancy)] {
        std::fs::write(dir.path().join(n), text).unwrap();
        let src = DataSource {
            data: n.into(),
            columns: BTreeMap::new(),
            fs: None,
            noise_data: None,
            gaps: Vec::new(),
            noise_gaps: Vec::new(),
        };
        let e = src
            .load("x", dir.path(), &["o1".into(), "o12".into()])
            .unwrap();
        loaded.push((e.fs, e.o.clone()));
    }
    assert_eq!(loaded[0], loaded[1]);
    assert!((loaded[0].0 - 10.0).abs() < 1e-9);
}

/// Through the command line: a dataset path that does not exist names the study file, the key
/// and the path (and does not load the parent directory's dataset); a CSV larger than the
/// memory budget is refused before it is read.
#[test]
fn command_line_dataset_path_and_budget() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    dataset().write(&d.join("ds")).unwrap();
    let study = |dataset: &str| {
        format!(
            "seed = 1\noutput = \"out\"\n[analysis]\ndataset = \"{dataset}\"\nband = [1e-2, 4.0]\n\
             [fit]\nfree = [\"a_df\", \"a_sus\", \"d21\", \"dt1\"]\nfixed = {{ w1sq = -1.3e-6, w2sq = -1.9e-6, dt2 = 0.2 }}\nchains = 2\niterations = 200\nburn_in = 100\n\
             [[experiment]]\nname = \"inv1\"\nfs = 10.0\npre_pad = 1.0\npost_pad = 1.0\nnoise_duration = 10.0\n\
             x1 = {{ kind = \"sine\", freq = 0.5, amplitude = 1e-6, duration = 4.0 }}\n"
        )
    };
    for p in ["ds/typo", "ds/typo/dataset.json", "nowhere"] {
        std::fs::write(d.join("s.toml"), study(p)).unwrap();
        let (ok, _, err) = common::occam(&["fit", "s.toml", "-q"], d);
        assert!(!ok);
        assert!(
            err.contains("s.toml") && err.contains("`analysis.dataset`") && err.contains(p),
            "{p}: {err}"
        );
        assert!(err.contains("cannot open the dataset"), "{p}: {err}");
    }
    // the budget, from the environment, before reading
    std::fs::write(d.join("big.csv"), good_csv().repeat(50)).unwrap();
    let text = "seed = 1\noutput = \"out2\"\n[analysis]\nband = [1e-2, 4.0]\n\
                [fit]\nfree = [\"a_df\", \"a_sus\", \"d21\", \"dt1\"]\nfixed = { w1sq = -1.3e-6, w2sq = -1.9e-6, dt2 = 0.2 }\nchains = 2\niterations = 200\nburn_in = 100\n\
                [[experiment]]\nname = \"inv1\"\ndata = \"big.csv\"\n";
    std::fs::write(d.join("b.toml"), text).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_occam"))
        .args(["fit", "b.toml", "-q"])
        .current_dir(d)
        // above the study's own needs (19 KiB), below the CSV's (9 × its 15 kB)
        .env("OCCAM_MEMORY_BUDGET", "64K")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("big.csv")
            && err.contains("memory budget of 65536 bytes")
            && err.contains("OCCAM_MEMORY_BUDGET"),
        "{err}"
    );
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_occam"))
        .args(["fit", "b.toml", "-q"])
        .current_dir(d)
        .env("OCCAM_MEMORY_BUDGET", "lots")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("OCCAM_MEMORY_BUDGET = \"lots\""), "{err}");
}

/// Inputs that are not regular files — a FIFO (which blocks a reader until a writer comes)
/// and a character device (`/dev/zero` never ends) — are refused by name, as data files, as
/// injection files and as study files, without blocking or reading.
#[cfg(unix)]
#[test]
fn special_files_are_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let fifo = d.join("pipe.csv");
    assert!(
        std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap()
            .success()
    );
    std::os::unix::fs::symlink("/dev/zero", d.join("zero.csv")).unwrap();
    std::os::unix::fs::symlink("/dev/zero", d.join("zero.npz")).unwrap();
    std::fs::write(
        d.join("study.toml"),
        "seed = 1\noutput = \"out\"\n[[experiment]]\nname = \"inv1\"\nfs = 2.0\nx12 = { kind = \"file\", path = \"pipe.csv\" }\n",
    )
    .unwrap();
    let d2 = d.to_path_buf();
    // on a regression the reads block or run out of memory: a thread with a deadline turns
    // that into a failure instead of a hung test
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let load = |f: &str, fs: Option<f64>| {
            let src = DataSource {
                data: f.into(),
                columns: BTreeMap::new(),
                fs,
                noise_data: None,
                gaps: Vec::new(),
                noise_gaps: Vec::new(),
            };
            let chans = vec!["o1".to_string(), "o12".to_string()];
            src.load("inv1", &d2, &chans)
                .map(|_| ())
                .unwrap_err()
                .to_string()
        };
        let study = |f: &str| {
            occam::config::Study::load(&d2.join(f))
                .map(|_| ())
                .unwrap_err()
                .to_string()
        };
        let got = vec![
            ("pipe.csv", "a FIFO", load("pipe.csv", None)),
            ("zero.csv", "a character device", load("zero.csv", None)),
            (
                "zero.npz",
                "a character device",
                load("zero.npz", Some(10.0)),
            ),
            ("pipe.csv", "a FIFO", study("study.toml")),
            ("pipe.csv", "a FIFO", study("pipe.csv")),
        ];
        tx.send(got).unwrap();
    });
    let got = rx
        .recv_timeout(std::time::Duration::from_secs(20))
        .expect("a special file blocked the reader");
    for (file, kind, e) in got {
        assert!(e.contains(file) && e.contains(kind), "{file}: {e}");
    }
}

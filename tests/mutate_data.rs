//! Mutation test of the dataset and CSV readers: a valid `dataset.json`/`dataset.npz` pair and
//! a valid CSV file, mutated deterministically (bit flips, truncation, inserted, deleted and
//! overwritten bytes, JSON fields set to extreme values, npy headers edited inside a
//! well-formed archive), 200 000 cases, each read inside `catch_unwind`. Every outcome must be `Ok` or `Err`:
//! zero panics. Prints the counts and the time.

use occam::data::dataset::{Dataset, ExperimentData, parse_csv};
use serde_json::Value;
use std::io::Write as _;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;
use std::time::Instant;

/// xorshift64*: a fixed sequence, so every run mutates the same way.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
    fn pick<'a, T>(&mut self, v: &'a [T]) -> &'a T {
        &v[self.below(v.len())]
    }
}

/// Bytes that matter to the formats: separators, quotes, digits, signs, zip and npy magic.
const INTERESTING: &[u8] = b"\x00\xff\x7f\x80\"',\n\r\t #.-+eE0159naif{}[]():PK\x93";

fn mutate_bytes(rng: &mut Rng, src: &[u8]) -> Vec<u8> {
    let mut b = src.to_vec();
    let rounds = 1 + rng.below(3);
    for _ in 0..rounds {
        let len = b.len();
        match rng.below(6) {
            0 => {
                for _ in 0..1 + rng.below(4) {
                    if !b.is_empty() {
                        let i = rng.below(b.len());
                        b[i] ^= 1 << rng.below(8);
                    }
                }
            }
            1 => b.truncate(rng.below(len + 1)),
            2 => {
                let at = rng.below(len + 1);
                let n = 1 + rng.below(8);
                let ins: Vec<u8> = (0..n)
                    .map(|_| {
                        if rng.below(2) == 0 {
                            *rng.pick(INTERESTING)
                        } else {
                            rng.next() as u8
                        }
                    })
                    .collect();
                b.splice(at..at, ins);
            }
            3 => {
                if len > 0 {
                    let at = rng.below(len);
                    let end = (at + 1 + rng.below(16)).min(len);
                    b.drain(at..end);
                }
            }
            4 => {
                if len > 0 {
                    let at = rng.below(len);
                    for i in at..(at + 1 + rng.below(8)).min(len) {
                        b[i] = rng.next() as u8;
                    }
                }
            }
            _ => {
                if len > 0 {
                    let at = rng.below(len);
                    let end = (at + 1 + rng.below(64)).min(len);
                    let chunk = b[at..end].to_vec();
                    let to = rng.below(b.len() + 1);
                    b.splice(to..to, chunk);
                }
            }
        }
    }
    b
}

/// Extreme and wrong-typed JSON values.
fn extreme(rng: &mut Rng) -> Value {
    let long = "x".repeat(70_000);
    let v = [
        serde_json::json!(1e308),
        serde_json::json!(-1e308),
        serde_json::json!(0),
        serde_json::json!(-0.0),
        serde_json::json!(5e-324),
        serde_json::json!(u64::MAX),
        serde_json::json!(i64::MIN),
        serde_json::json!(9007199254740993u64),
        serde_json::json!(-1),
        serde_json::json!(1e15),
        serde_json::json!(""),
        serde_json::json!(long),
        serde_json::json!("inv1"),
        Value::Null,
        serde_json::json!(true),
        serde_json::json!([]),
        serde_json::json!({}),
        serde_json::json!([1e308, -1]),
    ];
    rng.pick(&v).clone()
}

/// Every node of `v` as a JSON pointer.
fn pointers(v: &Value, at: String, out: &mut Vec<String>) {
    out.push(at.clone());
    match v {
        Value::Object(m) => {
            for (k, x) in m {
                pointers(x, format!("{at}/{k}"), out);
            }
        }
        Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                pointers(x, format!("{at}/{i}"), out);
            }
        }
        _ => {}
    }
}

/// Sets a random node of `v` to an extreme value (or removes a key, or adds an unknown one)
/// and serialises the result, sometimes damaging the text as well.
fn mutate_json(rng: &mut Rng, v: &Value, nodes: &[String]) -> Vec<u8> {
    let mut v = v.clone();
    let p = rng.pick(nodes).clone();
    match rng.below(8) {
        0 => {
            if let Some((parent, key)) = p.rsplit_once('/')
                && let Some(Value::Object(m)) = v.pointer_mut(parent)
            {
                m.remove(key);
            }
        }
        1 => {
            if let Some(Value::Object(m)) = v.pointer_mut(&p) {
                m.insert("unexpected".into(), extreme(rng));
            }
        }
        _ => {
            let x = extreme(rng);
            if let Some(n) = v.pointer_mut(&p) {
                *n = x;
            }
        }
    }
    let text = serde_json::to_vec_pretty(&v).unwrap();
    if rng.below(4) == 0 {
        mutate_bytes(rng, &text)
    } else {
        text
    }
}

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

/// The archive's entries, one npy header (shape, dtype, order) or data length edited, repacked
/// into a well-formed zip so that the npy reader (not the zip checksum) meets the damage.
fn mutate_npy_header(rng: &mut Rng, entries: &[(String, Vec<f64>)]) -> Vec<u8> {
    let k = rng.below(entries.len());
    let mut out = Vec::new();
    for (i, (n, v)) in entries.iter().enumerate() {
        let mut data: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
        let mut len = v.len().to_string();
        let mut descr = "<f8";
        let mut order = "False";
        let mut extra = "";
        if i == k {
            match rng.below(6) {
                0 => {
                    len = rng
                        .pick(&[
                            "0",
                            "1",
                            "63",
                            "65",
                            "2147483648",
                            "1152921504606846976",
                            "9223372036854775807",
                            "18446744073709551615",
                            "99999999999999999999999",
                            "-1",
                        ])
                        .to_string()
                }
                1 => descr = *rng.pick(&["<f4", ">f8", "|b1", "<c16", "<i8", "O", ""]),
                2 => order = *rng.pick(&["True", "1", "None"]),
                3 => extra = *rng.pick(&[", 7", ",)", "L", "1,", " 2, 3"]),
                4 => data.truncate(rng.below(data.len() + 1)),
                _ => data.extend((0..1 + rng.below(16)).map(|_| rng.next() as u8)),
            }
        }
        let h =
            format!("{{'descr': '{descr}', 'fortran_order': {order}, 'shape': ({len},{extra}), }}");
        let mut b = npy(&h, &data);
        if i == k && rng.below(4) == 0 {
            // damage the header text itself too
            let end = b.len().min(128);
            let m = mutate_bytes(rng, &b[..end]);
            b.splice(..end, m);
        }
        out.push((n.clone(), b));
    }
    zip(&out)
}

#[derive(Default, Debug)]
struct Counts {
    cases: usize,
    ok: usize,
    err: usize,
    panic: usize,
    first_panics: Vec<String>,
}

impl Counts {
    fn run<T, E>(&mut self, what: impl Fn() -> String, f: impl FnOnce() -> Result<T, E>) {
        self.cases += 1;
        match catch_unwind(AssertUnwindSafe(f)) {
            Ok(Ok(_)) => self.ok += 1,
            Ok(Err(_)) => self.err += 1,
            Err(p) => {
                self.panic += 1;
                if self.first_panics.len() < 5 {
                    let msg = p
                        .downcast_ref::<String>()
                        .cloned()
                        .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                        .unwrap_or_default();
                    self.first_panics.push(format!("{}: {msg}", what()));
                }
            }
        }
    }
}

fn sample() -> Dataset {
    let v = |a: f64, n: usize| (0..n).map(|k| a * (k as f64 + 1.0)).collect::<Vec<_>>();
    let mut e = ExperimentData::new(
        "inv1",
        10.0,
        [v(1.0, 32), v(2.0, 32)],
        [v(3.0, 32), v(4.0, 32)],
        [v(5.0, 16), v(6.0, 16)],
    );
    e.extra.insert("g1".into(), v(0.5, 32));
    e.noise_extra.insert("g1".into(), v(0.25, 16));
    Dataset {
        experiments: vec![e],
        seed: Some(1),
        truth: Some(Default::default()),
        extra: serde_json::json!({"note": "mutation test"}),
    }
}

#[test]
fn mutated_datasets_and_csv_files_never_panic() {
    let start = Instant::now();
    let dir = tempfile::tempdir().unwrap();
    let d = sample();
    let (npz_path, json_path) = d.write(dir.path()).unwrap();
    let npz = std::fs::read(&npz_path).unwrap();
    let json = std::fs::read(&json_path).unwrap();
    assert_eq!(Dataset::from_bytes(&json, &npz).unwrap(), d);
    let side: Value = serde_json::from_slice(&json).unwrap();
    let mut old = side.clone();
    old.as_object_mut().unwrap().remove("npz_digest");
    let old_json = serde_json::to_vec_pretty(&old).unwrap();
    assert_eq!(Dataset::from_bytes(&old_json, &npz).unwrap(), d);
    let e = &d.experiments[0];
    let mut entries: Vec<(String, Vec<f64>)> = vec![
        ("inv1.o1".into(), e.o[0].clone()),
        ("inv1.o12".into(), e.o[1].clone()),
        ("inv1.i1".into(), e.i[0].clone()),
        ("inv1.i12".into(), e.i[1].clone()),
        ("inv1.noise_o1".into(), e.noise[0].clone()),
        ("inv1.noise_o12".into(), e.noise[1].clone()),
        ("inv1.g1".into(), e.extra["g1"].clone()),
        ("inv1.noise_g1".into(), e.noise_extra["g1"].clone()),
        ("inv1.fs".into(), vec![10.0]),
    ];
    entries.push(("truth".into(), d.truth.unwrap().to_array().to_vec()));
    assert_eq!(
        Dataset::from_bytes(
            &old_json,
            &zip(&entries
                .iter()
                .map(|(n, v)| (
                    n.clone(),
                    npy(
                        &format!(
                            "{{'descr': '<f8', 'fortran_order': False, 'shape': ({},), }}",
                            v.len()
                        ),
                        &v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<_>>()
                    )
                ))
                .collect::<Vec<_>>())
        )
        .unwrap(),
        d
    );

    let mut csv = String::from("# a comment\nt,o1,o12,i1,i12\n");
    for k in 0..24 {
        csv += &format!(
            "{},{:e},{},\"{}\",0\n",
            0.1 * k as f64,
            1e-9 * k as f64,
            -(k as f64),
            k % 3
        );
    }
    let csv_path = Path::new("m.csv");
    assert!(
        parse_csv(csv_path, csv.as_bytes())
            .unwrap()
            .sample_rate()
            .unwrap()
            .is_some()
    );

    let prev = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let (mut json_c, mut npz_c, mut head_c, mut csv_c) = (
        Counts::default(),
        Counts::default(),
        Counts::default(),
        Counts::default(),
    );
    let mut nodes = Vec::new();
    pointers(&side, String::new(), &mut nodes);
    for i in 0..50_000 {
        let m = mutate_json(&mut rng, &side, &nodes);
        json_c.run(|| format!("json #{i}"), || Dataset::from_bytes(&m, &npz));
    }
    for i in 0..50_000 {
        let m = mutate_bytes(&mut rng, &npz);
        npz_c.run(
            || format!("npz bytes #{i}"),
            || Dataset::from_bytes(&old_json, &m),
        );
    }
    for i in 0..25_000 {
        let m = mutate_npy_header(&mut rng, &entries);
        head_c.run(
            || format!("npy header #{i}"),
            || Dataset::from_bytes(&old_json, &m),
        );
    }
    for i in 0..75_000 {
        let m = mutate_bytes(&mut rng, csv.as_bytes());
        csv_c.run(
            || format!("csv #{i}: {:?}", String::from_utf8_lossy(&m)),
            || {
                parse_csv(csv_path, &m).and_then(|t| {
                    t.sample_rate()
                        .map_err(|e| occam::data::dataset::DataError::Names { msg: e })
                })
            },
        );
    }
    std::panic::set_hook(prev);
    let secs = start.elapsed().as_secs_f64();
    let mut total = Counts::default();
    for (name, c) in [
        ("dataset.json fields", &json_c),
        ("dataset.npz bytes", &npz_c),
        ("npy headers", &head_c),
        ("CSV bytes", &csv_c),
    ] {
        eprintln!(
            "{name:>20}: {} cases, {} Ok, {} Err, {} panics",
            c.cases, c.ok, c.err, c.panic
        );
        total.cases += c.cases;
        total.ok += c.ok;
        total.err += c.err;
        total.panic += c.panic;
        total.first_panics.extend(c.first_panics.iter().cloned());
        // every class reaches both outcomes, or it is not testing the reader
        assert!(c.ok > 0 && c.err > 0, "{name}: {c:?}");
    }
    eprintln!(
        "{:>20}: {} cases, {} Ok, {} Err, {} panics in {secs:.1} s",
        "total", total.cases, total.ok, total.err, total.panic
    );
    assert!(total.cases >= 200_000);
    assert_eq!(total.panic, 0, "{:#?}", total.first_panics);
}

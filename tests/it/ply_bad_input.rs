//! Bad PLY input: every file in fixtures/ply/invalid fails with one line
//! naming the file and what is wrong, never a panic.

use std::collections::BTreeMap;

use crate::util::*;
use pcsss::formats::{self, Select};

fn expectations() -> BTreeMap<String, String> {
    let text = std::fs::read_to_string(fixtures().join("ply/invalid.txt")).unwrap();
    text.lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| {
            let (f, s) = l.split_once('\t').expect("NAME<TAB>SUBSTRING");
            (f.to_string(), s.to_string())
        })
        .collect()
}

#[test]
fn every_invalid_fixture_fails_in_the_library_with_its_message() {
    let exp = expectations();
    let dir = fixtures().join("ply/invalid");
    let mut seen = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_str().unwrap().to_string();
        let want = exp
            .get(&name)
            .unwrap_or_else(|| panic!("{name} is not listed in invalid.txt"));
        let bytes = std::fs::read(&path).unwrap();
        for sel in [Select::All, Select::only(&[])] {
            let err = formats::read_cloud(&bytes[..], &sel)
                .expect_err(&name)
                .to_string();
            assert!(
                err.contains(want.as_str()),
                "{name}: got '{err}', want '{want}'"
            );
            assert!(!err.contains('\n'), "{name}: message is one line");
        }
        seen += 1;
    }
    assert_eq!(seen, exp.len(), "every listed fixture exists");
}

#[test]
fn every_invalid_fixture_fails_in_the_binary_with_one_line() {
    let dir = fixtures().join("ply/invalid");
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        let p = path.to_str().unwrap();
        let out = run("pcinfo", &[p], b"");
        assert_eq!(out.status.code(), Some(1), "{p}");
        let err = stderr(&out);
        assert_eq!(err.lines().count(), 1, "{p}: {err}");
        assert!(err.starts_with(&format!("pcinfo: {p}: ")), "{err}");
        assert!(!err.contains("panicked"));
        // From stdin too, named as such.
        let out = run("pcinfo", &[], &std::fs::read(&path).unwrap());
        assert_eq!(out.status.code(), Some(1));
        assert!(
            stderr(&out).starts_with("pcinfo: <stdin>: "),
            "{}",
            stderr(&out)
        );
    }
}

#[test]
fn a_header_claiming_1e12_vertices_stays_within_bounded_memory() {
    // Under a 256 MiB address-space limit a reader that trusted the count
    // would abort; ours reads what is there and reports truncation.
    let p = fixtures().join("ply/invalid/huge_count.ply");
    let cmd = format!(
        "ulimit -v 262144; exec {} < {}",
        bin("pcinfo").display(),
        p.display()
    );
    let out = std::process::Command::new("bash")
        .args(["-c", &cmd])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(
        stderr(&out).contains("truncated: element 'vertex' ends at row 2 of 1000000000000"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn ascii_header_claiming_huge_list_reads_only_what_is_there() {
    let text = b"ply\nformat ascii 1.0\nelement face 1\nproperty list uint float v\nend_header\n4000000000 1 2 3\n";
    let err = formats::read_cloud(&text[..], &Select::All)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("truncated: element 'face' ends at row 0 of 1"),
        "{err}"
    );
}

#[test]
fn a_list_too_long_for_its_count_type_is_an_error_on_write() {
    use pcsss::{AttrData, Attribute, Column, Element, ListColumn, ScalarType};
    let mut l = ListColumn::new(ScalarType::U8, ScalarType::I32);
    l.items = Column::I32(vec![0; 300]);
    l.offsets = vec![0, 300];
    let mut e = Element::new("face", 1);
    e.set(Attribute {
        name: "vertex_indices".into(),
        data: AttrData::List(l),
    })
    .unwrap();
    let c = pcsss::Cloud {
        elements: vec![e],
        ..Default::default()
    };
    let err = formats::write_cloud(&mut Vec::new(), &c, LE)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("more than its count type uchar holds"),
        "{err}"
    );
}

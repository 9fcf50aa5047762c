//! PLY round trips: every encoding, every property type, unknown elements.

use crate::util::*;
use pcsss::formats::{self, Select};
use pcsss::{Cloud, DetailValue, Role, ScalarType};

#[test]
fn le_ascii_be_le_keeps_every_value_of_every_type() {
    let c0 = every_type_cloud();
    let le1 = to_bytes(&c0, LE);
    let c1 = from_bytes(&le1);
    assert_same_values(&c0, &c1);
    let asc = to_bytes(&c1, ASCII);
    let c2 = from_bytes(&asc);
    assert_same_values(&c0, &c2);
    let be = to_bytes(&c2, BE);
    let c3 = from_bytes(&be);
    assert_same_values(&c0, &c3);
    let le2 = to_bytes(&c3, LE);
    assert_eq!(le1, le2, "binary LE bytes identical after the whole chain");
}

#[test]
fn roles_and_detail_survive() {
    let c = from_bytes(&to_bytes(&every_type_cloud(), ASCII));
    let role = |n: &str| c.points().attr(n).unwrap().role();
    assert_eq!(role("P"), Some(Role::Point));
    assert_eq!(role("N"), Some(Role::Normal));
    assert_eq!(role("Cd"), Some(Role::Color));
    assert_eq!(role("rest"), Some(Role::Point));
    assert_eq!(role("vel"), Some(Role::Vector));
    assert_eq!(role("Nalt"), Some(Role::Normal));
    assert_eq!(c.detail("count"), Some(&DetailValue::I32(-7)));
    assert_eq!(c.detail_f64("Tarea").unwrap(), std::f64::consts::PI * 4.0);
    assert_eq!(
        c.detail("note"),
        Some(&DetailValue::Str("quotes \" and\nnewline, ünïcödé".into()))
    );
}

#[test]
fn ascii_header_uses_the_naming_convention() {
    let text = String::from_utf8(to_bytes(&every_type_cloud(), ASCII)).unwrap();
    let header = &text[..text.find("end_header").unwrap()];
    for line in [
        "property double x\nproperty double y\nproperty double z\n",
        "property float nx\nproperty float ny\nproperty float nz\n",
        "property uchar Cd_r\nproperty uchar Cd_g\nproperty uchar Cd_b\n",
        "property float rest_x\n",
        "property short vel_x\n",
        "comment pcsss role vertex rest point\n",
        "comment pcsss role vertex Nalt normal\n",
        "comment pcsss detail Tarea f64 12.566370614359172\n",
        "comment pcsss detail light_dir v3f 0 -1 1.1754944e-38\n",
        "element empty_rows 4\n",
        "property list uchar int vertex_indices\n",
    ] {
        assert!(header.contains(line), "header lacks {line:?}:\n{header}");
    }
}

#[test]
fn valid_fixtures_round_trip_through_every_encoding() {
    let dir = fixtures().join("ply/valid");
    let mut n = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        let bytes = std::fs::read(&path).unwrap();
        let c = formats::read_cloud(&bytes[..], &Select::All)
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        for f in [LE, BE, ASCII] {
            let back = from_bytes(&to_bytes(&c, f));
            assert_same_values(&c, &back);
        }
        n += 1;
    }
    assert!(n >= 2);
}

#[test]
fn unknown_elements_and_properties_come_back_intact() {
    // Values written by hand with Python's struct (see fixtures/ply/README.md).
    let bytes = std::fs::read(fixtures().join("ply/valid/unknown_elements_be.ply")).unwrap();
    let c = from_bytes(&bytes);
    let p = c.points().vec3_f64("P").unwrap();
    assert_eq!(p[0], [1e6, -1e6, 0.125]);
    assert_eq!(p[1], [1e6 + 0.5, -1e6, 1e-300]);
    assert_eq!(c.points().scalar_f64("flags").unwrap(), vec![-7.0, 127.0]);
    assert_eq!(c.points().scalar_f64("id").unwrap(), vec![65535.0, 0.0]);
    assert_eq!(
        c.points().scalar_f64("confidence").unwrap(),
        vec![0.5, f64::INFINITY]
    );
    let face = c.faces().unwrap();
    assert_eq!(face.scalar_f64("material").unwrap(), vec![-2147483648.0]);
    let cam = c.element("camera").unwrap();
    assert_eq!(cam.scalar_f64("view_px").unwrap(), vec![35.0]);
    let tags = cam.list("tags").unwrap();
    assert_eq!(tags.count_ty, ScalarType::U16);
    assert_eq!(tags.items.to_f64_vec(), vec![-32768.0, 32767.0]);
    assert_eq!(c.comments, vec!["made by hand for pcsss tests"]);
    assert_eq!(c.obj_info, vec!["scanner 42"]);
    // Written back big-endian, the file is byte for byte the same.
    assert_eq!(to_bytes(&c, BE), bytes);
}

#[test]
fn selected_read_decodes_only_what_is_asked_and_passes_the_rest_through() {
    let src = to_bytes(&every_type_cloud(), LE);
    let c = formats::read_cloud(&src[..], &Select::only(&["P"])).unwrap();
    let pts = c.points();
    assert!(pts
        .attr("P")
        .unwrap()
        .components()
        .iter()
        .all(|v| v.is_decoded()));
    for name in ["N", "s_float", "s_uint", "Cd", "rest"] {
        let a = pts.attr(name).unwrap();
        assert!(
            a.components().iter().all(|v| !v.is_decoded()),
            "{name} was decoded"
        );
    }
    // Undecoded columns are copied through; output equals input.
    assert_eq!(to_bytes(&c, LE), src);
    // And decode lazily, correctly, when asked for.
    assert_eq!(
        pts.scalar_f64("s_int").unwrap(),
        extremes(ScalarType::I32).to_f64_vec()
    );
    // A byte-order change decodes them.
    let be = to_bytes(&c, BE);
    assert_same_values(&from_bytes(&be), &every_type_cloud());
}

#[test]
fn modified_columns_replace_raw_bytes() {
    let src = to_bytes(&every_type_cloud(), LE);
    let mut c = formats::read_cloud(&src[..], &Select::only(&[])).unwrap();
    let pts = c.points_mut();
    pts.set_scalar("s_float", vec![1.0f32; 6]).unwrap();
    let back = from_bytes(&to_bytes(&c, LE));
    assert_eq!(back.points().scalar_f64("s_float").unwrap(), vec![1.0; 6]);
    assert_eq!(
        back.points().scalar_f64("s_int").unwrap(),
        extremes(ScalarType::I32).to_f64_vec()
    );
}

/// Undecoded properties are copied in spans of neighbours: a removed
/// attribute and a replaced one in the middle break the spans (the
/// output's offsets shift against the input's), and every other value
/// of every type still comes back, bit for bit.
#[test]
fn pass_through_spans_survive_removed_and_replaced_attributes() {
    let src = to_bytes(&every_type_cloud(), LE);
    let mut want = every_type_cloud();
    let pts = want.points_mut();
    pts.remove("s_short");
    pts.set_scalar("s_uint", vec![7.0f32; 6]).unwrap();
    let mut c = formats::read_cloud(&src[..], &Select::only(&[])).unwrap();
    let pts = c.points_mut();
    pts.remove("s_short");
    pts.set_scalar("s_uint", vec![7.0f32; 6]).unwrap();
    let back = from_bytes(&to_bytes(&c, LE));
    assert_same_values(&want, &back);
    // Nothing removed or replaced: one span, the input's bytes.
    let whole = formats::read_cloud(&src[..], &Select::only(&[])).unwrap();
    assert_eq!(to_bytes(&whole, LE), src);
}

#[test]
fn empty_cloud_round_trips() {
    let c = Cloud::with_points(0);
    for f in [LE, BE, ASCII] {
        let back = from_bytes(&to_bytes(&c, f));
        assert_eq!(back.len(), 0);
        assert_eq!(back.elements.len(), 1);
    }
}

#[test]
fn large_binary_crosses_chunk_boundaries() {
    // 300k points x 16 bytes: several 1 MiB chunks, an uneven last one.
    let n = 300_001;
    let mut c = Cloud::with_points(n);
    let p: Vec<[f32; 3]> = (0..n).map(|i| [i as f32, -(i as f32), 0.5]).collect();
    c.points_mut().set_vec3("P", Role::Point, &p).unwrap();
    c.points_mut()
        .set_scalar("id", (0..n as u32).collect())
        .unwrap();
    let b = to_bytes(&c, LE);
    for sel in [Select::All, Select::only(&["P"])] {
        let r = formats::read_cloud(&b[..], &sel).unwrap();
        assert_eq!(r.points().vec3_f32("P").unwrap(), p);
        assert_eq!(r.points().scalar_f64("id").unwrap()[n - 1], (n - 1) as f64);
    }
}

/// `PlyChunks` (the streaming reader `pctile` uses) against the whole
/// reader: for every encoding and chunk size, the chunks of each element
/// put together are the element read whole, and a body cut short fails
/// as truncated at the same row.
#[test]
fn chunked_reading_equals_whole_reading() {
    use pcsss::formats::ply::read::PlyChunks;
    use pcsss::Element;
    let c = every_type_cloud();
    for f in [LE, BE, ASCII] {
        let bytes = to_bytes(&c, f);
        let whole = from_bytes(&bytes);
        for max in [1, 2, 5, 1 << 16] {
            let mut r = PlyChunks::new(&bytes[..]).unwrap();
            let mut parts: Vec<Vec<Element>> = vec![Vec::new(); whole.elements.len()];
            while let Some((el, chunk)) = r.next_chunk(max).unwrap() {
                assert!(chunk.len() <= max || chunk.attrs().is_empty());
                parts[el].push(chunk);
            }
            for (e, ps) in whole.elements.iter().zip(&parts) {
                if e.attrs().is_empty() {
                    assert_eq!(ps.iter().map(|p| p.len()).sum::<usize>(), e.len());
                    continue;
                }
                let refs: Vec<&Element> = ps.iter().collect();
                let idx: Vec<(u32, u32)> = ps
                    .iter()
                    .enumerate()
                    .flat_map(|(k, p)| (0..p.len() as u32).map(move |i| (k as u32, i)))
                    .collect();
                let joined = Element::gather_from(&refs, &idx);
                let mut a = pcsss::Cloud::default();
                a.elements.push(e.clone());
                let mut b = pcsss::Cloud::default();
                b.elements.push(joined);
                assert_same_values(&a, &b);
            }
        }
        // Cut short: the same outcome as the whole reader's (an ASCII
        // body without its last line break is still whole).
        let head = bytes
            .windows(11)
            .position(|w| w == b"end_header\n")
            .unwrap()
            + 11;
        for cut in [head + 1, head + (bytes.len() - head) / 2, bytes.len() - 1] {
            let want = formats::read_cloud(&bytes[..cut], &formats::Select::All)
                .map(|_| ())
                .map_err(|e| e.to_string());
            let mut r = PlyChunks::new(&bytes[..cut]).unwrap();
            let got = loop {
                match r.next_chunk(3) {
                    Ok(Some(_)) => continue,
                    Ok(None) => break Ok(()),
                    Err(e) => break Err(e.to_string()),
                }
            };
            assert_eq!(got, want, "cut at {cut}");
        }
    }
}

/// A file read through its mapping (ASCII rows parsed in parallel, a
/// chunk of lines a task) and the same bytes read as a stream (row by
/// row): the same cloud, or the same error.
fn mapped_and_streamed(bytes: &[u8]) -> (pcsss::Result<Cloud>, pcsss::Result<Cloud>) {
    let d = tempdir();
    let path = d.path().join("in.ply");
    std::fs::write(&path, bytes).unwrap();
    (
        formats::read_cloud_file(&path, &Select::All),
        formats::read_cloud(bytes, &Select::All),
    )
}

#[test]
fn ascii_read_in_parallel_equals_the_row_by_row_read() {
    // Every type, lists and several elements; and a cloud large enough
    // for many chunks, whose lists' offsets must join across them.
    let p: Vec<[f64; 3]> = (0..60_000)
        .map(|i| [i as f64 * 0.25, -(i as f64), 1.0 / (i as f64 + 1.0)])
        .collect();
    let faces: Vec<Vec<i32>> = (0..200_000)
        .map(|i: i32| (0..i % 5).map(|k| i + k).collect())
        .collect();
    for (cloud, big) in [(every_type_cloud(), false), (mesh_from(&p, &faces), true)] {
        let bytes = to_bytes(&cloud, ASCII);
        assert!(!big || bytes.len() > 2 << 20, "several chunks");
        let (mapped, streamed) = mapped_and_streamed(&bytes);
        let (mapped, streamed) = (mapped.unwrap(), streamed.unwrap());
        assert_same_values(&streamed, &mapped);
        assert_same_values(&cloud, &mapped);
    }
}

#[test]
fn ascii_rows_not_one_a_line_still_read_and_errors_name_the_same_line() {
    let head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n";
    let bodies = [
        // One row a line, CRLF, trailing blanks, no newline at the end.
        "1 2\r\n3 4 \r\n5 6\n3 0 1 2\n2 1 2",
        // A row over two lines, two rows on one, a blank line.
        "1\n2\n3 4 5 6\n\n3 0 1 2\n2 1 2\n",
        // A list over lines.
        "1 2\n3 4\n5 6\n3 0\n1 2 2 1 2\n",
        // A count spelled as a float.
        "1 2\n3 4\n5 6\n3.0 0 1 2\n2 1 2\n",
    ];
    let want = from_bytes(format!("{head}1 2\n3 4\n5 6\n3 0 1 2\n2 1 2\n").as_bytes());
    for body in bodies {
        let (mapped, streamed) = mapped_and_streamed(format!("{head}{body}").as_bytes());
        assert_same_values(&want, &streamed.unwrap());
        assert_same_values(&want, &mapped.unwrap());
    }
    let bad = [
        "1 2\n3 x\n5 6\n3 0 1 2\n2 1 2\n",
        "1 2\n3 4\n5 6\n3 0 1 2\n-2 1 2\n",
        "1 2\n3 4\n5 6\n3 0 1 2\n",
        "1 2\n3 4\n5 6\n3 0 1 2\n2 1 2\n7\n",
        "1 2\n3 4\n5 6\n3 0 1 2\n2 1 \u{e9}\n",
        "1 2\n3 4\n",
    ];
    for body in bad {
        let (mapped, streamed) = mapped_and_streamed(format!("{head}{body}").as_bytes());
        let (m, s) = (
            mapped.unwrap_err().to_string(),
            streamed.unwrap_err().to_string(),
        );
        assert_eq!(m, s, "{body:?}");
    }
    // A list's count: negative, or too large for its type, named as such.
    for (body, says) in [
        ("1 2\n3 4\n5 6\n3 0 1 2\n-2 1 2\n", "has negative count -2"),
        (
            "1 2\n3 4\n5 6\n3 0 1 2\n256 1 2\n",
            "'256' is not a valid uchar",
        ),
    ] {
        let (mapped, streamed) = mapped_and_streamed(format!("{head}{body}").as_bytes());
        for e in [mapped.unwrap_err(), streamed.unwrap_err()] {
            assert!(e.to_string().contains(says), "{body:?}: {e}");
        }
    }
}

/// A float spelled in digits past its type's range is refused, naming
/// the line; "inf" and "nan" spelled out, the largest finite float and
/// the same digits in a double are read as written.
#[test]
fn an_ascii_float_past_its_range_is_refused_not_made_infinite() {
    let head = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty double y\nend_header\n";
    for bad in ["1e39", "-1e39", "3.5e38", "1e400"] {
        let (mapped, streamed) = mapped_and_streamed(format!("{head}0 0\n{bad} 1\n").as_bytes());
        for e in [mapped.unwrap_err(), streamed.unwrap_err()] {
            let e = e.to_string();
            assert!(
                e.contains(&format!("'{bad}' is not a valid float (past its range)"))
                    && e.contains("line"),
                "{bad}: {e}"
            );
        }
    }
    let (mapped, streamed) =
        mapped_and_streamed(format!("{head}inf 1e39\n3.4e38 -inf\n").as_bytes());
    for c in [mapped.unwrap(), streamed.unwrap()] {
        let x = c.points().scalar_f64("x").unwrap();
        let y = c.points().scalar_f64("y").unwrap();
        assert_eq!(x[0], f64::INFINITY);
        assert_eq!(x[1], 3.4e38f32 as f64);
        assert_eq!((y[0], y[1]), (1e39, f64::NEG_INFINITY));
    }
}

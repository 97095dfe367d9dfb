//! Tests of the `.vtu`, `.vtp` and `.pvd` writers: files written in every
//! encoding are read back with the minimal reader in `tests/reader.rs` (tag
//! balance, base64 with its `UInt64` header checked, the appended section
//! raw or zlib-compressed) and compared bit-exactly, and the public
//! [`read`] must read the same; bad input must give `Error::Io` and leave
//! no file.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use super::*;
use reader::{assert_well_formed, attributes, split_tag, Read};

mod reader;

/// A fresh, empty scratch folder for one test.
fn scratch(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("cgfem-vtu-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Every encoding.
const ENCODINGS: [VtuEncoding; 4] = [
    VtuEncoding::Appended,
    VtuEncoding::AppendedZlib,
    VtuEncoding::Binary,
    VtuEncoding::Ascii,
];

/// What a `DataArray` must read back as.
fn expected(a: &DataArray) -> Read {
    match &a.values {
        DataValues::F64(v) => Read::F64(v.iter().map(|x| x.to_bits()).collect()),
        DataValues::I64(v) => Read::I64(v.clone()),
        DataValues::I32(v) => Read::I32(v.clone()),
        DataValues::U8(v) => Read::U8(v.clone()),
    }
}

/// Attributes and values of every DataArray of a file, by the test reader.
type Arrays = Vec<(HashMap<String, String>, Read)>;

/// The file at `path`, read by the test reader: its XML (checked well
/// formed and laid out for `encoding`) and its DataArrays; the public
/// [`read`] must give the same arrays.
fn read_back(path: &Path, encoding: VtuEncoding) -> (String, Arrays) {
    let file = reader::parse(&std::fs::read(path).unwrap());
    assert_well_formed(&file.xml);
    let format = match encoding {
        VtuEncoding::Appended | VtuEncoding::AppendedZlib => "appended",
        VtuEncoding::Binary => "binary",
        VtuEncoding::Ascii => "ascii",
    };
    let compressed = file.xml.contains(r#"compressor="vtkZLibDataCompressor""#);
    assert_eq!(compressed, encoding == VtuEncoding::AppendedZlib);
    let arrays = reader::data_arrays(&file);
    for (attrs, _) in &arrays {
        assert_eq!(attrs["format"], format, "{}", attrs["Name"]);
    }
    let public = read(path).unwrap();
    assert_eq!(public.len(), arrays.len());
    for (a, (attrs, values)) in public.iter().zip(&arrays) {
        assert_eq!(a.name, attrs["Name"]);
        assert_eq!(a.components.to_string(), attrs["NumberOfComponents"]);
        assert_eq!(expected(a), *values, "{}", a.name);
    }
    (file.xml, arrays)
}

/// A hex8 cell on `[0,1]³` and a hex27 cell on `[1,2]×[0,1]²` sharing the
/// face `x = 1` (nodes listed lexicographically per cell, points deduplicated).
fn two_cell_mesh() -> VtuMesh {
    // Global points: a 5×3×3 lattice with spacing ½; hex8 uses its even nodes.
    let points: Vec<[f64; 3]> = (0..45)
        .map(|i| [i % 5, (i / 5) % 3, i / 15].map(|k| k as f64 * 0.5))
        .collect();
    let id = |i: usize, j: usize, k: usize| i + 5 * j + 15 * k;
    let hex8 = std::array::from_fn(|n| id(2 * (n % 2), 2 * ((n / 2) % 2), 2 * (n / 4)));
    let hex27 = std::array::from_fn(|n| id(2 + n % 3, (n / 3) % 3, n / 9));
    VtuMesh {
        points,
        cells: vec![
            VtuCell::hex8_from_lexicographic(hex8),
            VtuCell::hex27_from_lexicographic(hex27),
        ],
    }
}

fn point_arrays(n: usize) -> Vec<DataArray> {
    let mut special = vec![
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        -0.0,
        5e-324,
        0.1,
    ];
    special.extend((special.len()..n).map(|i| (i as f64).sqrt() * 1e-7));
    let vectors: Vec<[f64; 3]> = (0..n)
        .map(|i| [i as f64, -(i as f64) / 3.0, 1e300])
        .collect();
    let voigt: Vec<[f64; 6]> = (0..n)
        .map(|i| std::array::from_fn(|k| (i * 6 + k) as f64 / 7.0))
        .collect();
    vec![
        DataArray::scalars_f64("special", special),
        DataArray::vectors("displacement", &vectors),
        DataArray::sym_tensors("stress", &voigt),
        DataArray::scalars_i32("signed", (0..n as i32).map(|i| i * 1000 - 20_000).collect()),
    ]
}

fn cell_arrays() -> Vec<DataArray> {
    vec![
        DataArray::scalars_u8("classification", vec![0, 255]),
        DataArray::scalars_f64("energy", vec![1.0 / 3.0, f64::NAN]),
        DataArray::sym_tensors("mean stress", &[[1.0, 2.0, 3.0, 4.0, 5.0, 6.0], [0.0; 6]]),
        DataArray::scalars_u8(r#"a<b&"c'>"#, vec![7, 8]),
    ]
}

fn round_trip(encoding: VtuEncoding, test: &str) {
    let dir = scratch(test);
    let path = dir.join("two cells.vtu");
    let mesh = two_cell_mesh();
    let (pd, cd) = (point_arrays(mesh.points.len()), cell_arrays());
    write_vtu(&path, &mesh, &pd, &cd, encoding).unwrap();
    let (text, arrays) = read_back(&path, encoding);
    assert!(text.contains(r#"byte_order="LittleEndian" header_type="UInt64""#));
    assert!(text.contains(r#"<Piece NumberOfPoints="45" NumberOfCells="2">"#));

    let names: Vec<&str> = arrays.iter().map(|(a, _)| a["Name"].as_str()).collect();
    let ours: Vec<&DataArray> = pd.iter().chain(&cd).collect();
    assert_eq!(names.len(), ours.len() + 4);
    for ((attrs, values), a) in arrays.iter().zip(&ours) {
        assert_eq!(attrs["Name"], a.name);
        assert_eq!(attrs["NumberOfComponents"], a.components.to_string());
        assert_eq!(*values, expected(a), "{}", a.name);
    }
    let geometry = &arrays[ours.len()..];
    let coords = mesh.points.iter().flatten().map(|x| x.to_bits()).collect();
    assert_eq!(
        names[ours.len()..],
        ["Points", "connectivity", "offsets", "types"]
    );
    assert_eq!(geometry[0].1, Read::F64(coords));
    let connectivity: Vec<i64> = mesh
        .cells
        .iter()
        .flat_map(|c| c.nodes())
        .map(|&n| n as i64)
        .collect();
    assert_eq!(geometry[1].1, Read::I64(connectivity));
    assert_eq!(geometry[2].1, Read::I64(vec![8, 35]));
    assert_eq!(geometry[3].1, Read::U8(vec![12, 29]));
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn appended_file_round_trips_bit_exactly() {
    round_trip(VtuEncoding::Appended, "appended");
}

#[test]
fn compressed_file_round_trips_bit_exactly() {
    round_trip(VtuEncoding::AppendedZlib, "zlib");
}

#[test]
fn binary_file_round_trips_bit_exactly() {
    round_trip(VtuEncoding::Binary, "binary");
}

#[test]
fn large_arrays_round_trip_in_every_encoding() {
    // Arrays spanning several zlib blocks and base64 blocks, with a partial
    // last block.
    let dir = scratch("large");
    let path = dir.join("cloud.vtu");
    let n = 50_000;
    let points: Vec<[f64; 3]> = (0..n)
        .map(|i| [i as f64, (i as f64).sin(), (i as f64).sqrt()])
        .collect();
    let mesh = VtuMesh::point_cloud(points);
    let pd = [DataArray::scalars_f64(
        "noise",
        (0..n).map(|i| ((i * 7919) % 1013) as f64 / 3.0).collect(),
    )];
    for encoding in ENCODINGS {
        write_vtu(&path, &mesh, &pd, &[], encoding).unwrap();
        let (_, arrays) = read_back(&path, encoding);
        assert_eq!(arrays[0].1, expected(&pd[0]), "{encoding:?}");
        let coords = mesh.points.iter().flatten().map(|x| x.to_bits()).collect();
        assert_eq!(arrays[1].1, Read::F64(coords), "{encoding:?}");
    }
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn ascii_file_round_trips_bit_exactly() {
    round_trip(VtuEncoding::Ascii, "ascii");
}

#[test]
fn cells_list_vtk_reference_nodes() {
    // The hex27 cell's nodes, shifted back by x = 1, are VTK's reference
    // coordinates; the hex8 cell's are the corners of the same list.
    let mesh = two_cell_mesh();
    let at = |c: usize| -> Vec<[f64; 3]> {
        mesh.cells[c]
            .nodes()
            .iter()
            .map(|&n| mesh.points[n])
            .collect()
    };
    let hex27: Vec<[f64; 3]> = at(1).iter().map(|p| [p[0] - 1.0, p[1], p[2]]).collect();
    assert_eq!(hex27[8..20].iter().filter(|p| p.contains(&0.5)).count(), 12);
    assert_eq!(hex27[26], [0.5; 3]);
    assert_eq!(
        &hex27[20..26],
        &[
            [0.0, 0.5, 0.5],
            [1.0, 0.5, 0.5],
            [0.5, 0.0, 0.5],
            [0.5, 1.0, 0.5],
            [0.5, 0.5, 0.0],
            [0.5, 0.5, 1.0],
        ]
    );
    assert_eq!(at(0), hex27[..8].to_vec());
}

#[test]
fn sym_tensors_are_written_as_full_row_major_tensors() {
    let a = DataArray::sym_tensors("s", &[[11.0, 22.0, 33.0, 23.0, 13.0, 12.0]]);
    let full = [11.0, 12.0, 13.0, 12.0, 22.0, 23.0, 13.0, 23.0, 33.0];
    assert_eq!(a.components, 9);
    assert_eq!(a.values, DataValues::F64(full.to_vec()));
}

#[test]
fn point_cloud_has_one_vertex_cell_per_point() {
    let dir = scratch("cloud");
    let path = dir.join("cloud.vtu");
    let mesh = VtuMesh::point_cloud(vec![[0.0, 0.0, 0.0], [1.0, 2.0, 3.0], [-1.0, 0.5, 1e-3]]);
    let weights = DataArray::scalars_f64("weight", vec![0.25, 0.5, 0.25]);
    write_vtu(&path, &mesh, &[], &[weights], VtuEncoding::Appended).unwrap();
    let (_, arrays) = read_back(&path, VtuEncoding::Appended);
    let find = |name: &str| &arrays.iter().find(|(a, _)| a["Name"] == name).unwrap().1;
    assert_eq!(*find("connectivity"), Read::I64(vec![0, 1, 2]));
    assert_eq!(*find("offsets"), Read::I64(vec![1, 2, 3]));
    assert_eq!(*find("types"), Read::U8(vec![1, 1, 1]));
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn vtp_point_cloud_round_trips_with_its_vertices() {
    let dir = scratch("vtp");
    let path = dir.join("points.vtp");
    let points = vec![[0.0, 0.0, 0.0], [1.0, 2.0, 3.0], [-1.0, 0.5, 1e-3]];
    let gap = DataArray::scalars_f64("gap", vec![-1e-3, 0.0, 0.25]);
    for encoding in ENCODINGS {
        write_vtp_points(&path, &points, std::slice::from_ref(&gap), encoding).unwrap();
        let (text, arrays) = read_back(&path, encoding);
        assert!(text.contains("type=\"PolyData\""));
        assert!(text.contains("NumberOfVerts=\"3\""));
        let find = |name: &str| &arrays.iter().find(|(a, _)| a["Name"] == name).unwrap().1;
        assert_eq!(*find("connectivity"), Read::I64(vec![0, 1, 2]));
        assert_eq!(*find("offsets"), Read::I64(vec![1, 2, 3]));
        assert_eq!(*find("gap"), expected(&gap));
        let coords = DataArray::with("Points", 3, DataValues::F64(points.concat()));
        assert_eq!(*find("Points"), expected(&coords));
    }
    let short = DataArray::scalars_f64("gap", vec![0.0; 2]);
    std::fs::remove_dir_all(&dir).unwrap();
    std::fs::create_dir_all(&dir).unwrap();
    let bad = write_vtp_points(&path, &points, &[short], VtuEncoding::Binary);
    assert_rejected(&dir, bad, "'gap' has 2 values");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn vtp_triangles_round_trip_with_point_and_cell_data() {
    let dir = scratch("vtp-tri");
    let path = dir.join("surface.vtp");
    let points = vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.5],
    ];
    let triangles = [[0, 1, 2], [1, 3, 2]];
    let u = DataArray::vectors(
        "u",
        &[
            [0.1, 0.0, 0.0],
            [0.2, 0.0, 0.0],
            [0.3, 0.0, 0.0],
            [0.4, 0.0, 0.0],
        ],
    );
    let tag = DataArray::scalars_i32("tag", vec![0, 7]);
    for encoding in ENCODINGS {
        let (pd, cd) = (std::slice::from_ref(&u), std::slice::from_ref(&tag));
        write_vtp_triangles(&path, &points, &triangles, pd, cd, encoding).unwrap();
        let (text, arrays) = read_back(&path, encoding);
        assert!(text.contains("NumberOfVerts=\"0\""));
        assert!(text.contains("NumberOfPolys=\"2\""));
        assert!(text.contains("<Polys>") && text.contains("<CellData>"));
        let find = |name: &str| &arrays.iter().find(|(a, _)| a["Name"] == name).unwrap().1;
        assert_eq!(*find("connectivity"), Read::I64(vec![0, 1, 2, 1, 3, 2]));
        assert_eq!(*find("offsets"), Read::I64(vec![3, 6]));
        assert_eq!(*find("u"), expected(&u));
        assert_eq!(*find("tag"), expected(&tag));
    }
    std::fs::remove_dir_all(&dir).unwrap();
    std::fs::create_dir_all(&dir).unwrap();
    let bad = write_vtp_triangles(&path, &points, &[[0, 1, 4]], &[], &[], VtuEncoding::Binary);
    assert_rejected(&dir, bad, "refers to point 4");
    let short = DataArray::scalars_i32("tag", vec![0]);
    let bad = write_vtp_triangles(
        &path,
        &points,
        &triangles,
        &[],
        &[short],
        VtuEncoding::Binary,
    );
    assert_rejected(&dir, bad, "'tag' has 1 values");
    std::fs::remove_dir_all(dir).unwrap();
}

/// Asserts that writing fails with an `Error::Io` naming `path` whose reason
/// contains `needle`, and that the folder stays empty.
fn assert_rejected(dir: &Path, result: Result<()>, needle: &str) {
    match result {
        Err(Error::Io { path, reason }) => {
            assert!(path.starts_with(dir.to_str().unwrap()), "{path}");
            assert!(reason.contains(needle), "{reason:?} lacks {needle:?}");
        }
        other => panic!("expected Error::Io, got {other:?}"),
    }
    assert_eq!(
        std::fs::read_dir(dir).unwrap().count(),
        0,
        "a file was left"
    );
}

#[test]
fn bad_input_is_rejected_and_leaves_no_file() {
    let dir = scratch("bad");
    let path = dir.join("bad.vtu");
    let mesh = two_cell_mesh();
    let write = |m: &VtuMesh, pd: &[DataArray], cd: &[DataArray]| {
        write_vtu(&path, m, pd, cd, VtuEncoding::Appended)
    };
    let short = DataArray::vectors("u", &vec![[0.0; 3]; 44]);
    assert_rejected(
        &dir,
        write(&mesh, &[short], &[]),
        "'u' has 132 values, expected 45 points × 3",
    );
    let long = DataArray::scalars_u8("flag", vec![0; 3]);
    assert_rejected(
        &dir,
        write(&mesh, &[], &[long]),
        "'flag' has 3 values, expected 2 cells",
    );
    let empty = DataArray {
        name: "e".into(),
        components: 0,
        values: DataValues::I32(vec![]),
    };
    assert_rejected(&dir, write(&mesh, &[], &[empty]), "× 0 components");
    let twice = [
        DataArray::scalars_u8("c", vec![0; 2]),
        DataArray::scalars_u8("c", vec![1; 2]),
    ];
    assert_rejected(&dir, write(&mesh, &[], &twice), "'c' is given twice");
    let mut nan_point = mesh.clone();
    nan_point.points[7][1] = f64::NAN;
    assert_rejected(
        &dir,
        write(&nan_point, &[], &[]),
        "point 7 has a non-finite",
    );
    let mut dangling = mesh.clone();
    dangling.cells.push(VtuCell::Vertex(45));
    assert_rejected(
        &dir,
        write(&dangling, &[], &[]),
        "cell 2 refers to point 45",
    );
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn unwritable_path_is_an_io_error() {
    let dir = scratch("unwritable");
    let path = dir.join("missing folder").join("x.vtu");
    let result = write_vtu(&path, &VtuMesh::default(), &[], &[], VtuEncoding::Ascii);
    assert!(matches!(result, Err(Error::Io { .. })), "{result:?}");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn pvd_lists_time_steps_in_order() {
    let dir = scratch("pvd");
    let path = dir.join("series.pvd");
    let entries = [
        (0.0, "step 0.vtu"),
        (0.5, "load/step&1.vtu"),
        (1e-9, "s2.vtu"),
    ];
    write_pvd(&path, &entries).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert_well_formed(&text);
    assert!(text.contains(r#"<VTKFile type="Collection""#));
    let sets: Vec<HashMap<String, String>> = text
        .split("<DataSet")
        .skip(1)
        .map(|p| attributes(&format!("DataSet{}", split_tag(p).0.trim_end_matches('/'))))
        .collect();
    assert_eq!(sets.len(), 3);
    for (set, (time, file)) in sets.iter().zip(entries) {
        assert_eq!(set["timestep"].parse::<f64>().unwrap(), time);
        assert_eq!(set["file"], file);
    }
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn pvd_rejects_non_finite_time_and_leaves_no_file() {
    let dir = scratch("pvd-bad");
    let entries = [
        (0.0, PathBuf::from("a.vtu")),
        (f64::INFINITY, PathBuf::from("b.vtu")),
    ];
    let result = write_pvd(&dir.join("series.pvd"), &entries);
    assert_rejected(&dir, result, "entry 1: time inf is not finite");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn read_refuses_damaged_files() {
    let dir = scratch("damaged");
    let path = dir.join("cloud.vtp");
    let points: Vec<[f64; 3]> = (0..1000).map(|i| [i as f64, 0.5, -1.0]).collect();
    for encoding in [VtuEncoding::Appended, VtuEncoding::AppendedZlib] {
        write_vtp_points(&path, &points, &[], encoding).unwrap();
        let mut bytes = std::fs::read(&path).unwrap();
        bytes.truncate(bytes.len() / 2);
        std::fs::write(&path, &bytes).unwrap();
        match read(&path) {
            Err(Error::Io { reason, .. }) => {
                assert!(reason.contains("run past the data"), "{reason}")
            }
            other => panic!("{encoding:?}: expected Error::Io, got {other:?}"),
        }
    }
    std::fs::remove_dir_all(dir).unwrap();
}

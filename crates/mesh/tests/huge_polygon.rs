//! A mesh that is one huge polygon (a single OBJ `f` line of thousands of vertices) must not
//! make queries near it test every triangle: the work per query is counted (the triangle
//! tests of a budgeted closest-point query), not timed.

use std::path::Path;

use mesh::{load_mesh_bytes, InsideTest, MeshQuery};

/// A regular `n`-gon of radius 50 in the plane z = 0, as one OBJ face.
fn polygon_obj(n: usize) -> Vec<u8> {
    let mut text = String::new();
    for i in 0..n {
        let a = std::f64::consts::TAU * i as f64 / n as f64;
        text += &format!("v {} {} 0\n", 50.0 * a.cos(), 50.0 * a.sin());
    }
    text += "f";
    for i in 1..=n {
        text += &format!(" {i}");
    }
    text += "\n";
    text.into_bytes()
}

#[test]
fn queries_near_a_huge_polygon_test_few_triangles() {
    let n = 20_000;
    let loaded = load_mesh_bytes(&polygon_obj(n), Path::new("polygon.obj")).unwrap();
    assert_eq!(loaded.mesh.triangles.len(), n - 2);
    // As the tree builders query an open mesh: holes closed, winding-number inside test.
    let (closed, holes) = loaded.mesh.with_holes_closed();
    assert_eq!(holes, 1);
    let query = MeshQuery::with_inside_test(&closed, InsideTest::WindingNumber);
    // A fan from one vertex needs about n tests for most of these points; the level-by-level
    // split needs a few per level (about 15 levels here).
    let budget = 2_000;
    let mut worst = 0usize;
    for i in 0..200 {
        let a = i as f64 * 0.731;
        let r = 49.0 * ((i as f64 * 0.37) % 1.0);
        let p = [r * a.cos(), r * a.sin(), 0.5 + (i % 7) as f64];
        let (found, complete) = query.closest_budgeted(p, f64::INFINITY, budget);
        assert!(
            complete,
            "the query at {p:?} needed more than {budget} triangle tests"
        );
        let d = found.unwrap().distance;
        assert!((d - p[2]).abs() < 1e-9, "distance {d} at {p:?}");
        // The smallest budget that completes, by bisection: the work this query needs.
        let (mut lo, mut hi) = (0usize, budget);
        while lo + 1 < hi {
            let mid = (lo + hi) / 2;
            if query.closest_budgeted(p, f64::INFINITY, mid).1 {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        worst = worst.max(hi);
    }
    assert!(worst < n / 20, "a query needed {worst} triangle tests");
}

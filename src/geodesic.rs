//! Areas of polygons on the WGS84 ellipsoid (Karney's, crate `geographiclib-rs`),
//! many geometries in one call, in shapely's `to_ragged_array` layout
//! (`geodesic_areas` in `geoalpha/_kernel.pyi`).

use geographiclib_rs::{Geodesic, PolygonArea, Winding};
use rayon::prelude::*;

/// Checks that `offsets` runs from 0 up to `n`, the length of what it indexes.
fn check_offsets(name: &str, offsets: &[i64], n: usize) -> Result<(), String> {
    let (first, last) = match offsets {
        [first, .., last] | [first @ last] => (*first, *last),
        [] => return Err(format!("{name}: must hold at least one value (0)")),
    };
    if first != 0 {
        return Err(format!("{name}: must start at 0; got {first}"));
    }
    if usize::try_from(last).ok() != Some(n) {
        return Err(format!(
            "{name}: must end at {n} (what it indexes); got {last}"
        ));
    }
    match offsets.windows(2).position(|w| w[1] < w[0]) {
        Some(k) => Err(format!(
            "{name}: must not decrease; got {} then {} at position {k}",
            offsets[k],
            offsets[k + 1]
        )),
        None => Ok(()),
    }
}

/// The area (m²) of one ring (the side smaller than half the ellipsoid); a
/// repeated closing vertex is dropped, fewer than three vertices give 0.
pub fn ring_area(geod: &Geodesic, lon: &[f64], lat: &[f64]) -> f64 {
    let mut n = lon.len();
    if n > 1 && lon[0] == lon[n - 1] && lat[0] == lat[n - 1] {
        n -= 1;
    }
    if n < 3 {
        return 0.0;
    }
    let mut ring = PolygonArea::new(geod, Winding::CounterClockwise);
    for k in 0..n {
        ring.add_point(lat[k], lon[k]);
    }
    ring.compute(true).1.abs()
}

/// The area (m²) of every geometry: exteriors minus holes, polygons summed;
/// the errors are those of `geodesic_areas` (`geoalpha/_kernel.pyi`).
pub fn polygon_areas(
    lon: &[f64],
    lat: &[f64],
    ring_offsets: &[i64],
    polygon_offsets: &[i64],
    geometry_offsets: &[i64],
) -> Result<Vec<f64>, String> {
    if lon.len() != lat.len() {
        return Err(format!(
            "lon and lat must have the same length; got {} and {}",
            lon.len(),
            lat.len()
        ));
    }
    check_offsets("ring_offsets", ring_offsets, lon.len())?;
    check_offsets("polygon_offsets", polygon_offsets, ring_offsets.len() - 1)?;
    check_offsets(
        "geometry_offsets",
        geometry_offsets,
        polygon_offsets.len() - 1,
    )?;
    let bad = (lon.par_iter().zip(lat.par_iter()))
        .position_any(|(&x, &y)| !(x.is_finite() && y.is_finite() && y.abs() <= 90.0));
    if let Some(k) = bad {
        return Err(format!(
            "vertex {k} is no longitude/latitude in degrees (finite, latitude within \
             [-90, 90]); got ({}, {})",
            lon[k], lat[k]
        ));
    }
    let at = |o: &[i64], k: usize| o[k] as usize;
    let geod = Geodesic::wgs84();
    let areas = (0..geometry_offsets.len() - 1).into_par_iter().map(|g| {
        (at(geometry_offsets, g)..at(geometry_offsets, g + 1))
            .flat_map(|p| {
                let rings = at(polygon_offsets, p)..at(polygon_offsets, p + 1);
                rings.clone().map(move |r| (r, r == rings.start))
            })
            .fold(0.0, |total, (r, exterior)| {
                let v = at(ring_offsets, r)..at(ring_offsets, r + 1);
                let area = ring_area(&geod, &lon[v.clone()], &lat[v]);
                total + if exterior { area } else { -area }
            })
    });
    Ok(areas.collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// WGS84: semi-major axis (m) and flattening.
    const A: f64 = 6_378_137.0;
    const F: f64 = 1.0 / 298.257_223_563;

    /// Area between the equator and latitude `phi` (radians) over one radian
    /// of longitude: b² times the closed form of the ellipsoid's zone,
    /// sin φ / (2 (1 - e² sin² φ)) + atanh(e sin φ) / (2e).
    fn zone(phi: f64) -> f64 {
        let e2 = F * (2.0 - F);
        let e = e2.sqrt();
        let b2 = A * A * (1.0 - e2);
        let s = phi.sin();
        b2 * (s / (2.0 * (1.0 - e2 * s * s)) + (e * s).atanh() / (2.0 * e))
    }

    fn one(lon: &[f64], lat: &[f64]) -> f64 {
        let n = lon.len() as i64;
        polygon_areas(lon, lat, &[0, n], &[0, 1], &[0, 1]).unwrap()[0]
    }

    #[test]
    fn the_triangle_from_the_equator_to_the_pole_is_the_closed_form() {
        // Two meridians one degree apart and the equator are geodesics, so
        // the triangle (0, 0), (1, 0), the north pole is exactly the zone
        // from the equator to the pole over one degree of longitude.
        let expected = zone(90.0_f64.to_radians()) * 1.0_f64.to_radians();
        let got = one(&[0.0, 1.0, 0.0], &[0.0, 0.0, 90.0]);
        assert!(
            ((got - expected) / expected).abs() < 1e-12,
            "{got} {expected}"
        );
        // the same in the south, clockwise
        let south = one(&[0.0, 0.0, 1.0], &[0.0, -90.0, 0.0]);
        assert!(((south - expected) / expected).abs() < 1e-12, "{south}");
    }

    #[test]
    fn the_one_degree_cell_at_the_equator() {
        // pyproj's Geod(ellps="WGS84").polygon_area_perimeter([0, 1, 1, 0],
        // [0, 0, 1, 1]) gives 12308778361.469452 m²; the cell bounded by
        // parallels (the closed form, whose northern edge is no geodesic) is
        // within 1e-4 of it
        let got = one(&[0.0, 1.0, 1.0, 0.0], &[0.0, 0.0, 1.0, 1.0]);
        assert!((got / 12_308_778_361.469_452 - 1.0).abs() < 1e-12, "{got}");
        let zone_cell = zone(1.0_f64.to_radians()) * 1.0_f64.to_radians();
        assert!((got / zone_cell - 1.0).abs() < 1e-4, "{got} {zone_cell}");
        // 0.001 degree wide, the geodesic along the parallel at 1 degree
        // leaves it by less than 1e-10 of the cell
        let w: f64 = 0.001;
        let narrow = one(&[0.0, w, w, 0.0], &[0.0, 0.0, 1.0, 1.0]);
        let zone_narrow = zone(1.0_f64.to_radians()) * w.to_radians();
        assert!(
            (narrow / zone_narrow - 1.0).abs() < 1e-9,
            "{narrow} {zone_narrow}"
        );
    }

    #[test]
    fn a_cap_around_the_pole_is_the_cap() {
        // 360 vertices on the parallel at 80 degrees, either way round: the
        // cap north of them (a little less: geodesic edges bulge poleward),
        // not the rest of the ellipsoid
        let lon: Vec<f64> = (0..360).map(|k| k as f64 - 180.0).collect();
        let lat = vec![80.0; 360];
        let cap = zone(90.0_f64.to_radians()) - zone(80.0_f64.to_radians());
        let cap = cap * std::f64::consts::TAU;
        let up = one(&lon, &lat);
        let rev: Vec<f64> = lon.iter().rev().copied().collect();
        let down = one(&rev, &lat);
        assert!((up / down - 1.0).abs() < 1e-12, "{up} {down}");
        assert!(up < cap && up > cap * 0.999, "{up} {cap}");
    }

    #[test]
    fn holes_are_taken_out_and_parts_summed() {
        // one polygon with a hole, then a multipolygon of two cells either
        // side of the antimeridian, then an empty geometry
        let lon = [
            0.0, 2.0, 2.0, 0.0, 0.0, // exterior, closed
            0.5, 0.5, 1.5, 1.5, // hole, clockwise
            179.0, 180.0, 180.0, 179.0, // east of 180
            -180.0, -179.0, -179.0, -180.0, // west of 180
        ];
        let lat = [
            0.0, 0.0, 2.0, 2.0, 0.0, //
            0.5, 1.5, 1.5, 0.5, //
            0.0, 0.0, 1.0, 1.0, //
            0.0, 0.0, 1.0, 1.0,
        ];
        let got =
            polygon_areas(&lon, &lat, &[0, 5, 9, 13, 17], &[0, 2, 3, 4], &[0, 1, 3, 3]).unwrap();
        let big = one(&lon[..5], &lat[..5]);
        let hole = one(&lon[5..9], &lat[5..9]);
        let cell = one(&[0.0, 1.0, 1.0, 0.0], &[0.0, 0.0, 1.0, 1.0]);
        assert_eq!(got[0], big - hole);
        assert!((got[1] / (2.0 * cell) - 1.0).abs() < 1e-12);
        assert_eq!(got[2], 0.0);
        // the same cell straddling the line in one ring, unwrapped longitudes
        let across = one(&[179.5, 180.5, 180.5, 179.5], &[0.0, 0.0, 1.0, 1.0]);
        assert!((across / cell - 1.0).abs() < 1e-12);
    }

    #[test]
    fn bad_input_is_an_error() {
        let e = polygon_areas(&[0.0], &[], &[0], &[0], &[0]).unwrap_err();
        assert_eq!(e, "lon and lat must have the same length; got 1 and 0");
        let e = polygon_areas(
            &[0.0, 1.0, 1.0],
            &[0.0, 0.0, 91.0],
            &[0, 3],
            &[0, 1],
            &[0, 1],
        )
        .unwrap_err();
        assert!(e.to_string().contains("vertex 2"), "{e}");
        let e = polygon_areas(&[0.0; 3], &[0.0; 3], &[0, 2], &[0, 1], &[0, 1]).unwrap_err();
        assert!(
            e.to_string().starts_with("ring_offsets: must end at 3"),
            "{e}"
        );
        let e = polygon_areas(&[], &[], &[], &[0], &[0]).unwrap_err();
        assert!(e.to_string().starts_with("ring_offsets"), "{e}");
        let e = polygon_areas(&[0.0; 3], &[0.0; 3], &[0, 3], &[0, 1], &[1, 0, 1]).unwrap_err();
        assert!(e.to_string().contains("start at 0"), "{e}");
    }
}

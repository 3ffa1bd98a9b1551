//! A local flat-earth NED frame about an origin given in latitude, longitude and altitude.
//! Good to a few centimetres over the few hundred metres a small helicopter flies.

/// WGS-84 equatorial radius (m).
const EARTH_A_M: f64 = 6_378_137.0;
/// WGS-84 first eccentricity squared.
const EARTH_E2: f64 = 6.694_379_990_14e-3;

/// The origin of the local NED frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GeoOrigin {
    /// Latitude (deg).
    pub lat_deg: f64,
    /// Longitude (deg).
    pub lon_deg: f64,
    /// Altitude above mean sea level (m).
    pub alt_m: f64,
}

impl GeoOrigin {
    /// Meridian and prime-vertical radii of curvature at the origin (m).
    fn radii(&self) -> (f64, f64) {
        let s = self.lat_deg.to_radians().sin();
        let d = 1.0 - EARTH_E2 * s * s;
        let n = EARTH_A_M / d.sqrt();
        let m = EARTH_A_M * (1.0 - EARTH_E2) / (d * d.sqrt());
        (m, n)
    }

    /// NED position (m) of a point.
    pub fn to_ned(&self, lat_deg: f64, lon_deg: f64, alt_m: f64) -> [f64; 3] {
        let (m, n) = self.radii();
        let north = (lat_deg - self.lat_deg).to_radians() * (m + self.alt_m);
        let east = (lon_deg - self.lon_deg).to_radians()
            * (n + self.alt_m)
            * self.lat_deg.to_radians().cos();
        [north, east, self.alt_m - alt_m]
    }

    /// Latitude, longitude (deg) and altitude (m) of a NED position.
    pub fn to_geodetic(&self, ned_m: [f64; 3]) -> (f64, f64, f64) {
        let (m, n) = self.radii();
        let [north, east, down] = ned_m;
        let lat = self.lat_deg + (north / (m + self.alt_m)).to_degrees();
        let lon = self.lon_deg
            + (east / ((n + self.alt_m) * self.lat_deg.to_radians().cos())).to_degrees();
        (lat, lon, self.alt_m - down)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_is_exact_to_the_millimetre() {
        let o = GeoOrigin {
            lat_deg: 42.36,
            lon_deg: -71.09,
            alt_m: 10.0,
        };
        let (lat, lon, alt) = o.to_geodetic([120.0, -35.0, -12.5]);
        let back = o.to_ned(lat, lon, alt);
        assert!((back[0] - 120.0).abs() < 1e-6);
        assert!((back[1] + 35.0).abs() < 1e-6);
        assert!((back[2] + 12.5).abs() < 1e-9);
    }

    #[test]
    fn one_arc_minute_of_latitude_is_about_a_nautical_mile() {
        let o = GeoOrigin {
            lat_deg: 45.0,
            lon_deg: 0.0,
            alt_m: 0.0,
        };
        let ned = o.to_ned(45.0 + 1.0 / 60.0, 0.0, 0.0);
        assert!((ned[0] - 1852.0).abs() < 5.0, "{}", ned[0]);
    }
}

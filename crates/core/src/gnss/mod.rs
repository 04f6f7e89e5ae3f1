//! GNSS geometry: orbits from almanac/ephemeris, line of sight, double differences (`SEEDS.md §3`).

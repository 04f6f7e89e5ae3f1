//! Strapdown INS: mechanization, alignment, IMU error model (`SEEDS.md §1`).

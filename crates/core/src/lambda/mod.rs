//! Integer least squares: LAMBDA decorrelation and search (Teunissen 1995; `SEEDS.md §3`).

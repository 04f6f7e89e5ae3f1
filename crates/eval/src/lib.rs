//! navfuse-eval: a sink that aligns solutions with a reference by time and produces error series and summary statistics.

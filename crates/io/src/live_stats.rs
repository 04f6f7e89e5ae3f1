//! Bounded-memory counters of a live session: gaps in a stream's time
//! stamps ([`GapCounter`]) and a latency histogram ([`LatencyHistogram`]).

// ---------------------------------------------------------------- gaps

/// Counts gaps in a stream's time stamps: an interval longer than
/// [`GapCounter::FACTOR`] × the stream's period, the period being the
/// shortest interval seen so far (the data's own rate, so no rate needs to be
/// configured). 1.5 periods is halfway between one interval (nothing
/// missing) and two (one record missing): a longer interval means at least
/// one record is missing whatever the jitter below half a period.
#[derive(Clone, Debug, Default)]
pub struct GapCounter {
    last: Option<f64>,
    period: f64,
    /// Gaps seen.
    pub gaps: u64,
    /// Their total length [s] (the missing time, interval − period).
    pub gap_s: f64,
    /// The longest interval of a gap [s].
    pub longest_s: f64,
}

impl GapCounter {
    pub const FACTOR: f64 = 1.5;

    /// Time `t` [s] of the next record (non-increasing times are ignored:
    /// the readers count those as rejections). Returns true at a gap.
    pub fn push(&mut self, t: f64) -> bool {
        let Some(last) = self.last else {
            self.last = Some(t);
            return false;
        };
        let dt = t - last;
        if dt <= 0.0 {
            return false;
        }
        self.last = Some(t);
        if self.period == 0.0 || dt < self.period {
            self.period = dt;
            return false;
        }
        if dt > Self::FACTOR * self.period {
            self.gaps += 1;
            self.gap_s += dt - self.period;
            self.longest_s = self.longest_s.max(dt);
            return true;
        }
        false
    }
}

// ---------------------------------------------------------------- latency

/// Histogram of latencies: 10 µs bins up to 10 s, plus an overflow count.
/// Bounded memory for any run length.
#[derive(Clone, Debug)]
pub struct LatencyHistogram {
    bins: Vec<u32>,
    over: u64,
    n: u64,
    max: f64,
}

impl Default for LatencyHistogram {
    fn default() -> Self {
        LatencyHistogram {
            bins: vec![0; 1_000_000],
            over: 0,
            n: 0,
            max: 0.0,
        }
    }
}

impl LatencyHistogram {
    const BIN: f64 = 1e-5;

    pub fn add(&mut self, seconds: f64) {
        let s = seconds.max(0.0);
        self.n += 1;
        self.max = self.max.max(s);
        let k = (s / Self::BIN) as usize;
        match self.bins.get_mut(k) {
            Some(b) => *b = b.saturating_add(1),
            None => self.over += 1,
        }
    }

    pub fn count(&self) -> u64 {
        self.n
    }

    pub fn max(&self) -> f64 {
        self.max
    }

    /// Quantile `q` ∈ [0, 1] [s] (upper edge of its bin; NaN when empty).
    pub fn quantile(&self, q: f64) -> f64 {
        if self.n == 0 {
            return f64::NAN;
        }
        let rank = ((q.clamp(0.0, 1.0) * self.n as f64).ceil() as u64).max(1);
        let mut acc = 0u64;
        for (k, &b) in self.bins.iter().enumerate() {
            acc += u64::from(b);
            if acc >= rank {
                return (k + 1) as f64 * Self::BIN;
            }
        }
        self.max
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaps_are_counted_from_the_data_rate() {
        let mut g = GapCounter::default();
        let ts = [
            0.0, 0.01, 0.02, 0.034, 0.045, 0.065, 0.075, 1.075, 1.085, 1.085,
        ];
        let hits: Vec<bool> = ts.iter().map(|&t| g.push(t)).collect();
        // 0.014 (jitter) is not a gap; 0.02 (one missing) and 1.0 are.
        assert_eq!(g.gaps, 2, "{hits:?}");
        assert!(hits[5] && hits[7]);
        assert!((g.longest_s - 1.0).abs() < 1e-9);
        assert!((g.gap_s - (0.01 + 0.99)).abs() < 1e-9);
    }

    #[test]
    fn latency_quantiles() {
        let mut h = LatencyHistogram::default();
        for k in 1..=100 {
            h.add(k as f64 * 1e-4);
        }
        assert!((h.quantile(0.5) - 50e-4).abs() < 1.5e-5);
        assert!((h.quantile(0.99) - 99e-4).abs() < 1.5e-5);
    }
}

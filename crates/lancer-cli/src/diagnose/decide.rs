//! How `lancer diagnose` weighs each render against the student's image, and its decision
//! rule. Everything is in the display domain (sRGB-encoded values clamped to [0, 1]), over
//! every layer compared, one after the other.
//!
//! A mistake is judged where it shows: on the pixels where its render differs from the right
//! model's (by more than [`DIFFER`] in a channel). There the image is either closer to the
//! mistake or to the right model; elsewhere the two agree and tell nothing. A whole-image
//! PSNR alone would drown a mistake that changes a few pixels (a shadow, a reflection) in the
//! rest of the image.
//!
//! The rule:
//! - a mistake **explains** the image when, on its pixels, the image is at least [`MARGIN_DB`]
//!   closer to it than to the right model, and at least [`EXPLAINED_DB`] close to it;
//! - the verdict is the mistake that explains the image with the best PSNR over the whole
//!   image; **unclear** when another one that explains it is within [`TIE_DB`] of it;
//! - when none explains it: **correct** when the right model's PSNR is at least
//!   [`CORRECT_DB`], or at least [`CLOSE_DB`] and every mistake is **refuted** (on its pixels
//!   the image is at least [`MARGIN_DB`] closer to the right model than to it); else
//!   **unclear**.

use glam::Vec3;

use crate::diff::metrics::psnr;

/// Two renders differ at a pixel when a channel differs by more than this (two 8-bit steps:
/// an image written in 8 bits, or by another renderer's rounding, does not make one).
pub(crate) const DIFFER: f32 = 2.0 / 255.0;
/// How much closer (dB) to a mistake than to the right model the image must be, where they
/// differ, for the mistake to explain it.
pub(crate) const MARGIN_DB: f64 = 6.0;
/// How close (dB) to the mistake the image must be there.
pub(crate) const EXPLAINED_DB: f64 = 30.0;
/// The right model's PSNR from which, with no mistake explaining the image, it is correct.
pub(crate) const CORRECT_DB: f64 = 45.0;
/// The right model's PSNR from which it is correct when it also refutes every mistake.
pub(crate) const CLOSE_DB: f64 = 30.0;
/// Two mistakes that explain the image within this many dB of each other are not told apart.
pub(crate) const TIE_DB: f64 = 1.0;

/// How one mistake's render compares with the image and the right model's render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Score {
    /// The image against the mistake's render, over every pixel (infinite: identical).
    pub(crate) psnr: f64,
    /// The pixels where the mistake's render differs from the right model's.
    pub(crate) differing: usize,
    /// All the pixels compared.
    pub(crate) pixels: usize,
    /// The image against the mistake's render on the pixels where it differs.
    pub(crate) there: f64,
    /// The image against the right model's render on those pixels.
    pub(crate) right_there: f64,
}

impl Score {
    /// The share of the pixels where the mistake differs from the right model.
    pub(crate) fn share(&self) -> f64 {
        self.differing as f64 / self.pixels.max(1) as f64
    }

    /// Whether the mistake explains the image (see the module's rule).
    pub(crate) fn explains(&self) -> bool {
        self.differing > 0 && self.there >= self.right_there + MARGIN_DB && self.there >= EXPLAINED_DB
    }

    /// Whether the image refutes the mistake: where it shows, the image is clearly closer to
    /// the right model.
    pub(crate) fn refuted(&self) -> bool {
        self.right_there >= self.there + MARGIN_DB
    }
}

/// The mean squared error of two equally long runs of display values, every channel.
fn mse(a: &[Vec3], b: &[Vec3]) -> f64 {
    let sum: f64 = a.iter().zip(b).map(|(p, q)| f64::from((*p - *q).length_squared())).sum();
    sum / (3 * a.len().max(1)) as f64
}

/// The image's PSNR against a render (display values, as long).
pub(crate) fn psnr_of(image: &[Vec3], render: &[Vec3]) -> f64 {
    psnr(mse(image, render))
}

/// The score of the mistake whose render is `mistake`, for the image `image` and the right
/// model's render `right` (display values, all as long).
pub(crate) fn score(image: &[Vec3], right: &[Vec3], mistake: &[Vec3]) -> Score {
    let (mut sq, mut sq_right, mut differing) = (0.0f64, 0.0f64, 0usize);
    for ((i, r), m) in image.iter().zip(right).zip(mistake) {
        if (*r - *m).abs().max_element() > DIFFER {
            differing += 1;
            sq += f64::from((*i - *m).length_squared());
            sq_right += f64::from((*i - *r).length_squared());
        }
    }
    let n = (3 * differing.max(1)) as f64;
    let (there, right_there) =
        if differing == 0 { (f64::INFINITY, f64::INFINITY) } else { (psnr(sq / n), psnr(sq_right / n)) };
    Score { psnr: psnr_of(image, mistake), differing, pixels: image.len(), there, right_there }
}

/// The indices of `scores`, the mistake that explains the image best first: by PSNR over the
/// whole image, then where it differs from the right model.
pub(crate) fn ranked(scores: &[Score]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..scores.len()).collect();
    order.sort_by(|&a, &b| scores[b].psnr.total_cmp(&scores[a].psnr).then(scores[b].there.total_cmp(&scores[a].there)));
    order
}

/// What the rule says.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Verdict {
    /// The right model explains the image.
    Correct,
    /// The mistake of this index explains it.
    Mistake(usize),
    /// Nothing clearly does; the candidates of these indices come closest, best first.
    Unclear(Vec<usize>),
}

/// The verdict and why, in words (names from `names`, parallel to `scores`).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Decision {
    pub(crate) verdict: Verdict,
    pub(crate) reason: String,
}

/// `x` dB, or "identical" for an infinite PSNR.
pub(crate) fn db(x: f64) -> String {
    if x.is_infinite() { "identical".to_owned() } else { format!("{x:.1} dB") }
}

/// The rule of the module's documentation: `right` is the right model's PSNR, `scores` the
/// mistakes' (those whose render differs from the right one somewhere), `names` their names.
pub(crate) fn decide(right: f64, scores: &[Score], names: &[&str]) -> Decision {
    let order = ranked(scores);
    let explaining: Vec<usize> = order.iter().copied().filter(|&k| scores[k].explains()).collect();
    if let Some(&best) = explaining.first() {
        let s = &scores[best];
        let tied: Vec<usize> = explaining
            .iter()
            .copied()
            .filter(|&k| s.psnr == scores[k].psnr || s.psnr - scores[k].psnr < TIE_DB)
            .collect();
        if tied.len() > 1 {
            let list: Vec<String> = tied.iter().map(|&k| format!("{} ({})", names[k], db(scores[k].psnr))).collect();
            return Decision {
                verdict: Verdict::Unclear(tied),
                reason: format!("{} explain the image about as well as each other", list.join(" and ")),
            };
        }
        return Decision {
            verdict: Verdict::Mistake(best),
            reason: format!(
                "where {} differs from the right model ({:.2} % of the pixels), the image matches it ({}) and not the right model ({})",
                names[best],
                100.0 * s.share(),
                db(s.there),
                db(s.right_there)
            ),
        };
    }
    if right.is_infinite() {
        return Decision { verdict: Verdict::Correct, reason: "the image is the right model's render".to_owned() };
    }
    if right >= CORRECT_DB {
        return Decision {
            verdict: Verdict::Correct,
            reason: format!(
                "the right model's render matches the image (PSNR {}, at least {CORRECT_DB} dB) and no mistake explains the differences",
                db(right)
            ),
        };
    }
    if right >= CLOSE_DB && scores.iter().all(Score::refuted) {
        return Decision {
            verdict: Verdict::Correct,
            reason: format!(
                "the right model's render is close to the image ({}), and where each mistake would show the image is at least {MARGIN_DB} dB closer to the right model",
                db(right)
            ),
        };
    }
    let top: Vec<usize> = order.iter().copied().take(3).collect();
    let best = order.first().map(|&k| scores[k].psnr).unwrap_or(f64::NEG_INFINITY);
    let reason = if right < 20.0 && best < 20.0 {
        format!(
            "the image is far from every render (the right model: {}): is it this scene, with this camera and size?",
            db(right)
        )
    } else if right >= CLOSE_DB {
        format!(
            "the right model's render is close ({}), but where some mistakes would show the image is not clearly closer to it: other settings (--samples, a variant of a term) or a difference the catalogue does not know",
            db(right)
        )
    } else {
        format!(
            "no mistake of the catalogue explains the differences (the right model: {}): two mistakes at once, or one the catalogue does not know",
            db(right)
        )
    };
    Decision { verdict: Verdict::Unclear(top), reason }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A run of `n` display values: `base` everywhere, `v` on the pixels `spot` takes.
    fn run(n: usize, base: f32, v: f32, spot: impl Fn(usize) -> bool) -> Vec<Vec3> {
        (0..n).map(|i| Vec3::splat(if spot(i) { v } else { base })).collect()
    }

    #[test]
    fn a_mistake_is_judged_on_the_pixels_where_it_shows() {
        // The mistake changes 10 pixels of 1000 from 0.5 to 0.9: the whole-image PSNRs are
        // both high, but there the image matches the mistake, not the right model.
        let n = 1000;
        let right = run(n, 0.5, 0.5, |_| false);
        let mistake = run(n, 0.5, 0.9, |i| i % 100 == 0);
        let s = score(&mistake, &right, &mistake);
        assert_eq!((s.differing, s.pixels), (10, 1000));
        assert!(s.psnr.is_infinite() && (s.right_there - psnr(0.16)).abs() < 1e-5, "{s:?}");
        assert!(s.explains());
        let r = psnr_of(&mistake, &right);
        assert!(r > 27.0, "{r}: the whole image is close");
        let d = decide(r, &[s], &["shadows:past-light"]);
        assert_eq!(d.verdict, Verdict::Mistake(0), "{}", d.reason);
        assert!(d.reason.contains("(1.00 % of the pixels)"), "{}", d.reason);
        // The right image: the right model is identical, the mistake is rejected.
        let s = score(&right, &right, &mistake);
        assert!(!s.explains() && s.right_there.is_infinite());
        assert_eq!(decide(f64::INFINITY, &[s], &["m"]).verdict, Verdict::Correct);
    }

    #[test]
    fn noise_or_a_small_difference_is_not_a_mistake_and_a_tie_is_unclear() {
        let n = 1000;
        let right = run(n, 0.5, 0.5, |_| false);
        // Another renderer's rounding: every pixel off by 1/255, the mistake off by 3/255 on a
        // few pixels. It does not explain; the right model is within 48 dB: correct.
        let image = run(n, 0.5 + 1.0 / 255.0, 0.5, |_| false);
        let small = run(n, 0.5, 0.5 + 3.0 / 255.0, |i| i < 50);
        let s = score(&image, &right, &small);
        assert!(!s.explains(), "{s:?}");
        let d = decide(psnr_of(&image, &right), &[s], &["m"]);
        assert_eq!(d.verdict, Verdict::Correct, "{}", d.reason);
        // Two mistakes that give the same image: not told apart.
        let m = run(n, 0.5, 1.0, |i| i < 100);
        let s = score(&m, &right, &m);
        let d = decide(psnr_of(&m, &right), &[s, s], &["a", "b"]);
        assert_eq!(d.verdict, Verdict::Unclear(vec![0, 1]), "{}", d.reason);
        // An image unlike everything: unclear, and the reason says how far it is.
        let other = run(n, 0.0, 0.0, |_| false);
        let d = decide(psnr_of(&other, &right), &[score(&other, &right, &m)], &["a"]);
        assert_eq!(d.verdict, Verdict::Unclear(vec![0]));
        assert!(d.reason.contains("far from every render"), "{}", d.reason);
        // Half-way between the right model and the mistake where they differ: neither.
        let half = run(n, 0.5, 0.75, |i| i < 100);
        let s = score(&half, &right, &m);
        assert!(!s.explains());
        assert!(matches!(decide(psnr_of(&half, &right), &[s], &["a"]).verdict, Verdict::Unclear(_)));
    }
}

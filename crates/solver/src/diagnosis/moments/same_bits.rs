//! A check of the tests: two sets of moments the same bit for bit.

use super::Moments;

/// Asserts that two sets of moments are the same bit for bit (the tests of the carries:
/// carried moments against those formed afresh).
pub(crate) fn assert_same_bits(a: &Moments, b: &Moments) {
    assert_eq!((a.m, a.u), (b.m, b.u));
    for (x, y) in a.runs.iter().zip(&b.runs) {
        assert_eq!(x.z, y.z);
        assert_eq!(x.xx, y.xx);
        assert_eq!(x.xu, y.xu);
    }
    assert_eq!(a.peaks, b.peaks);
    assert_eq!(a.varies, b.varies);
    assert_eq!(a.local, b.local);
}

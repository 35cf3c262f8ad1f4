//! Arrays that traversal reads at random (the BVH's nodes, the leaves' packets) and the
//! builder's working array, allocated so that Linux backs them with 2 MiB pages.
//!
//! A ray through the 1.31 M-triangle mesh touches about a dozen nodes and packets spread over
//! 100 MB: with 4 KiB pages nearly every one of those loads also misses the TLB and walks the
//! page table, which 2 MiB pages (50 of them instead of 25,000) all but remove. Where the
//! kernel's transparent huge pages are in `madvise` mode (Debian's default, and the project's
//! machine), an allocation has them only if the program asks, before it first touches the
//! memory: Embree asks for every large allocation, and so it traced that mesh's incoherent
//! rays at 1.4x raylab's rate until raylab asked too (`docs/performance.md`).
//!
//! The advice is only that: where the kernel has no huge page to give, or on other systems,
//! the memory is ordinary memory and nothing else changes.

use rayon::prelude::*;

/// Arrays smaller than this are not worth the advice (they fit in a few TLB entries anyway).
const MIN_BYTES: usize = 4 << 20;

/// An empty vector with room for `len` elements, advised to be backed by huge pages.
pub fn with_capacity<T>(len: usize) -> Vec<T> {
    let mut v = Vec::with_capacity(len);
    advise(&mut v);
    v
}

/// The items of `iter` in order, in a vector advised to be backed by huge pages, filled in
/// parallel (each element written once, straight into its place).
pub fn collect<T: Send>(iter: impl IndexedParallelIterator<Item = T>) -> Vec<T> {
    let mut v = with_capacity(iter.len());
    iter.collect_into_vec(&mut v);
    v
}

/// `v`'s elements in a vector of exactly their number, advised to be backed by huge pages (a
/// copy when `v` is large; otherwise `v` shrunk to its length).
pub fn copy_of<T: Copy>(mut v: Vec<T>) -> Vec<T> {
    if std::mem::size_of_val(v.as_slice()) < MIN_BYTES {
        v.shrink_to_fit();
        return v;
    }
    let mut out = with_capacity(v.len());
    out.extend_from_slice(&v);
    out
}

/// Advises the kernel to back `v`'s allocation (its whole capacity) with huge pages.
#[cfg(target_os = "linux")]
fn advise<T>(v: &mut Vec<T>) {
    const PAGE: usize = 4096;
    let bytes = v.capacity() * std::mem::size_of::<T>();
    if bytes < MIN_BYTES {
        return;
    }
    // The advice takes whole pages: from the first page boundary in the allocation to the
    // last (the kernel then uses huge pages for the 2 MiB-aligned stretches inside).
    let start = v.as_mut_ptr() as usize;
    let first = start.next_multiple_of(PAGE);
    let last = (start + bytes) & !(PAGE - 1);
    if last > first {
        // SAFETY: `first..last` lies inside `v`'s allocation, which `v` owns and keeps alive
        // for the call; MADV_HUGEPAGE changes how the kernel backs those pages, never their
        // contents or whether they can be read and written. A failure (no huge page support)
        // leaves ordinary pages, which is all the advice can fail to give, so its result is
        // not needed.
        unsafe {
            libc::madvise(
                first as *mut libc::c_void,
                last - first,
                libc::MADV_HUGEPAGE,
            );
        }
    }
}

#[cfg(not(target_os = "linux"))]
fn advise<T>(_: &mut Vec<T>) {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn collected_and_copied_arrays_keep_their_elements_in_order() {
        for len in [0, 1, 1000, (MIN_BYTES / 4) + 17] {
            let v = collect((0..len as u32).into_par_iter().map(|i| i * 3));
            assert_eq!(v.len(), len);
            assert!(v.iter().enumerate().all(|(i, &x)| x == i as u32 * 3));
            let c = copy_of(v.clone());
            assert_eq!(c, v);
            assert_eq!(c.capacity(), len);
        }
    }
}

//! CPU priority of the calling thread.

/// Lowers the calling thread's CPU priority by `steps` of nice (Linux keeps a nice
/// value per thread; threads it starts afterwards inherit it). Lowering needs no
/// privilege; the result is clamped to the lowest priority, nice 19.
pub fn lower_this_thread(steps: u8) -> std::io::Result<()> {
    // getpriority may return -1 as a value: errno tells an error apart.
    // SAFETY: getpriority and setpriority read and write the scheduling attribute of
    // the calling thread (`who` 0 with PRIO_PROCESS on Linux) and touch no memory.
    unsafe {
        *libc::__errno_location() = 0;
        let current = libc::getpriority(libc::PRIO_PROCESS, 0);
        if current == -1 && *libc::__errno_location() != 0 {
            return Err(std::io::Error::last_os_error());
        }
        let lowered = (current + i32::from(steps)).min(19);
        if libc::setpriority(libc::PRIO_PROCESS, 0, lowered) != 0 {
            return Err(std::io::Error::last_os_error());
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn nice_of_this_thread() -> i32 {
        // SAFETY: as in lower_this_thread.
        unsafe { libc::getpriority(libc::PRIO_PROCESS, 0) }
    }

    #[test]
    fn lowers_only_the_calling_thread_and_the_threads_it_starts() {
        let before = nice_of_this_thread();
        let (lowered, inherited) = std::thread::spawn(move || {
            lower_this_thread(5).unwrap();
            let inherited = std::thread::spawn(nice_of_this_thread).join().unwrap();
            (nice_of_this_thread(), inherited)
        })
        .join()
        .unwrap();
        assert_eq!(lowered, (before + 5).min(19));
        assert_eq!(inherited, lowered);
        assert_eq!(nice_of_this_thread(), before);
    }
}

//! Work shared out over the machine's cores when an instrument is built
//! (never on the audio thread), each piece's result the same as one loop's.

/// Indices worked on in one go.
const STRETCH: usize = 64;

/// The most threads work is shared out over.
const MAX_THREADS: usize = 8;

/// What `each` pushes for every index in `0..count`, in that order: the
/// indices in stretches of [`STRETCH`], dealt out in turn over the cores (a
/// stretch no thread could be started for is worked here).
pub(crate) fn in_stretches<T: Send>(count: usize, each: &(dyn Fn(usize, &mut Vec<T>) + Sync)) -> Vec<T> {
    let stretches = count.div_ceil(STRETCH);
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get()).clamp(1, MAX_THREADS).min(stretches.max(1));
    let work = |hand: usize| -> Vec<(usize, Vec<T>)> {
        (hand..stretches)
            .step_by(cores)
            .map(|s| {
                let mut found = Vec::new();
                (s * STRETCH..((s + 1) * STRETCH).min(count)).for_each(|x| each(x, &mut found));
                (s, found)
            })
            .collect()
    };
    let mut done: Vec<(usize, Vec<T>)> = std::thread::scope(|scope| {
        let workers: Vec<_> = (1..cores)
            .map(|hand| std::thread::Builder::new().spawn_scoped(scope, move || work(hand)).map_err(|_| hand))
            .collect();
        let mut done = work(0);
        for worker in workers {
            match worker {
                Ok(w) => done.extend(w.join().unwrap_or_else(|e| std::panic::resume_unwind(e))),
                Err(hand) => done.extend(work(hand)),
            }
        }
        done
    });
    done.sort_by_key(|(s, _)| *s);
    done.into_iter().flat_map(|(_, found)| found).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Shared out over the cores, what each index pushes comes in the order one
    /// loop pushes it, however many each index makes (none, one or several).
    #[test]
    fn stretches_join_in_order() {
        for count in [0, 1, STRETCH - 1, STRETCH, 5 * STRETCH + 3] {
            let each = |x: usize, out: &mut Vec<(usize, usize)>| out.extend((0..x % 3).map(|j| (x, j)));
            let mut serial = Vec::new();
            (0..count).for_each(|x| each(x, &mut serial));
            assert_eq!(in_stretches(count, &each), serial, "{count}");
        }
    }
}

//! The tables of the averaged law that a set of runs shares, as a value: a sweep, a single run
//! or a Python call owns one and hands it down to every run, so a reader sees which runs share a
//! table (a sweep over `k_d` builds one table for all its drives).

use crate::averaged::orbit::AveragingError;
use crate::averaged::table::{SHARED, Table, table_span};
use crate::model::Params;
use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

/// One table's slot: built once, by the first run that asks; runs of the same table wait for it.
type Slot = Arc<OnceLock<Result<Arc<Table>, AveragingError>>>;

/// The averaged law's tables by [`TableStore::key`], built on first demand with the options
/// [`SHARED`] over `[0, table_span(p)]`. Cloning a store shares its tables (the clone is a
/// handle); a new store starts empty. Building is deterministic, so a shared table is the one
/// each run would build, and results never depend on which runs share a store.
#[derive(Clone, Debug, Default)]
pub struct TableStore {
    tables: Arc<Mutex<HashMap<Vec<u64>, Slot>>>,
}

impl TableStore {
    /// An empty store.
    pub fn new() -> Self {
        Self::default()
    }

    /// The slot of `key`, made empty where there is none yet.
    fn slot(&self, key: Vec<u64>) -> Slot {
        // A poisoned lock only means a run panicked while holding it: the map itself is sound.
        let mut map = self.tables.lock().unwrap_or_else(|e| e.into_inner());
        map.entry(key).or_default().clone()
    }

    /// The averaged law of `p` (its `f`, `u0`, `v_d`, mass and contact; `k_d`, `h_d` and `t_on`
    /// do not enter) over `[0, table_span(p)]` with the options [`SHARED`], built once per store
    /// and shared by every run that asks the store for it.
    pub fn table(&self, p: &Params) -> Result<Arc<Table>, AveragingError> {
        let slot = self.slot(Self::key(p));
        // Built outside the map's lock: runs of other tables go on meanwhile; runs of this one
        // wait for it.
        slot.get_or_init(|| Table::build(p, table_span(p), SHARED).map(Arc::new))
            .clone()
    }

    /// The table of `p` where this store has built or been given it already; `None` otherwise
    /// (it is not built here).
    pub fn cached(&self, p: &Params) -> Option<Arc<Table>> {
        let slot = self
            .tables
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .get(&Self::key(p))?
            .clone();
        slot.get()?.as_ref().ok().cloned()
    }

    /// Hands the store a table kept from an earlier process (a sweep's journal) under its
    /// [`TableStore::key`], so that it is not built again. A table already there stays.
    pub fn preload(&self, key: Vec<u64>, table: Table) {
        let _ = self.slot(key).set(Ok(Arc::new(table)));
    }

    /// What identifies the table of `p`: the bits of every parameter but `k_d`, `h_d` and
    /// `t_on`.
    pub fn key(p: &Params) -> Vec<u64> {
        let mut key_p = *p;
        key_p.k_d = 0.0;
        key_p.h_d = 0.0;
        key_p.t_on = 0.0;
        crate::model::params::PARAMS
            .iter()
            .map(|i| i.get(&key_p).to_bits())
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use crate::averaged::store::TableStore;
    use crate::model::Params;

    #[test]
    fn a_store_builds_a_table_once_and_its_clones_share_it() {
        let p = Params {
            f: 3000.0,
            v_d: 5e-4,
            u0: 2e-8,
            ..Params::default()
        };
        let store = TableStore::new();
        assert!(store.cached(&p).is_none(), "a new store is empty");
        let a = store.table(&p).expect("a law");
        // Another drive shares the table; a clone of the store is the same store.
        let q = Params {
            k_d: 2.0 * p.k_d,
            ..p
        };
        let b = store.clone().table(&q).expect("a law");
        assert!(std::sync::Arc::ptr_eq(&a, &b));
        // Another store builds its own, equal to the first (building is deterministic).
        let c = TableStore::new().table(&p).expect("a law");
        assert!(!std::sync::Arc::ptr_eq(&a, &c));
        assert_eq!(*a, *c);
        // Another amplitude is another table.
        let r = Params { u0: 4e-8, ..p };
        assert!(store.cached(&r).is_none());
    }
}

//! A model update through the store: the transfer into the inactive slot, the commit that
//! authenticates it, writes its header and state words and loads it, and the log record of
//! its outcome.

use fbg_shared::blob::stored_crc;
use fbg_shared::container::{self, Envelope};
use fbg_shared::protocol::{RejectReason, Rejection};
use fbg_shared::signature::{KeyId, SignatureError};
use fbg_shared::Compensator;

use super::format::{
    is_blank, sector_erases, EventKind, Record, SlotHeader, ACTIVE, ACTIVE_AT, COMPLETE, COMPLETE_AT, FLAG_ROLLBACK,
    PAYLOAD_AT, REVOKED, REVOKED_AT, SLOT_HEADER_AT, UNIT,
};
use super::{accepted_record, MappedFlash, Store, ERASE_BUDGET, REFUSALS_LOGGED, SLOTS};
use crate::{authenticate, load_blob, Kernel, ModelInfo, Policy, Signer};

impl<F: MappedFlash> Store<F> {
    /// The slot an update is written to: never the running one; with the embedded default
    /// running, the older of the two.
    fn inactive(&self) -> usize {
        match self.running {
            Some(s) => (usize::from(s) + 1) % SLOTS,
            None => usize::from(self.generation(1) < self.generation(0)),
        }
    }

    /// The generation slot `slot`'s header records (0 without a whole header).
    fn generation(&self, slot: usize) -> u32 {
        self.view(slot).header.map_or(0, |h| h.generation)
    }

    /// Start a transfer of `total` bytes whose CRC-32 is `crc` into the inactive slot: checked
    /// against the limit first, then the slot is made blank — erased unless it is blank already
    /// (within [`ERASE_BUDGET`]), its erase count written again. Any earlier transfer is
    /// forgotten.
    #[inline(never)]
    pub fn begin(&mut self, total: usize, crc: u32) -> Result<(), Rejection> {
        self.receiving = None;
        self.staging.check(total)?;
        let slot = self.inactive();
        let s = self.flash.sector(slot);
        let ready = sector_erases(s).is_some() && s.get(UNIT..).is_some_and(is_blank);
        if !ready {
            let base = slot * F::ERASE_SIZE;
            if is_blank(s) {
                // Never written (a factory-fresh part): only its count is missing.
                self.format_blank(slot).map_err(|_| storage(base))?;
            } else {
                if u32::from(self.erases_unaccepted) >= ERASE_BUDGET {
                    return Err(Rejection { reason: RejectReason::EraseLimit, detail: ERASE_BUDGET });
                }
                self.transfer_erases = self.transfer_erases.wrapping_add(1);
                self.erases_unaccepted = self.erases_unaccepted.saturating_add(1);
                self.erase_sector(slot).map_err(|_| storage(base))?;
            }
        }
        self.staging.begin(slot * F::ERASE_SIZE + PAYLOAD_AT, total, crc);
        self.receiving = Some(slot as u8);
        Ok(())
    }

    /// Append a chunk that starts at byte `at` of the transfer; returns the bytes received so
    /// far.
    #[inline(never)]
    pub fn chunk(&mut self, at: u32, data: &[u8]) -> Result<usize, Rejection> {
        self.staging.chunk(&mut self.flash, at, data)
    }

    /// Forget the transfer in progress (after a refusal).
    pub fn abort(&mut self) {
        self.staging.abort();
        self.receiving = None;
    }

    /// End the transfer and, when it is whole and authentic against `policy` and the `running`
    /// model (and the rollback floor), make it the model that boots and load it into `comp`
    /// (see the module docs for the order of the writes). The outcome is logged — a refusal
    /// within [`REFUSALS_LOGGED`] per accepted update.
    #[inline(never)]
    pub fn commit<const K: usize>(
        &mut self,
        kernel: &Kernel<K>,
        policy: &Policy,
        comp: &mut Compensator<f32, K>,
        running: &ModelInfo,
    ) -> Result<ModelInfo, Rejection> {
        let announced = self.staging.announced();
        let slot = self.receiving.take().map(usize::from);
        let Some(slot) = slot else {
            self.staging.abort();
            return Err(Rejection::new(RejectReason::NoUpdateInProgress));
        };
        let result = self.commit_to(kernel, policy, comp, running, slot);
        match result {
            Ok(_) => {
                self.erases_unaccepted = 0;
                self.refusals_since_accept = 0;
            }
            Err(r) => self.log_refusal(r, slot, announced.unwrap_or(0)),
        }
        result
    }

    /// The commit's steps, each in its own frame so that none of their temporaries is on the
    /// stack while the model loads (the deepest the stack goes).
    #[inline(never)]
    fn commit_to<const K: usize>(
        &mut self,
        kernel: &Kernel<K>,
        policy: &Policy,
        comp: &mut Compensator<f32, K>,
        running: &ModelInfo,
        slot: usize,
    ) -> Result<ModelInfo, Rejection> {
        let (total, blob_len, signer) = self.authentic(policy, running, slot)?;
        let header = self.activate(slot, total, blob_len, signer)?;
        let loaded = {
            let blob = self.flash.sector(slot).get(PAYLOAD_AT..PAYLOAD_AT + blob_len).unwrap_or(&[]);
            load_blob(kernel, comp, blob)
        };
        match loaded {
            Ok(info) => {
                self.running = Some(slot as u8);
                let flags = if signer.serial < running.serial { FLAG_ROLLBACK } else { 0 };
                // A failure leaves the slot booting; the log is repaired at the next boot.
                let _ = self.append(accepted_record(slot, &header, flags));
                Ok(info.signed_by(Some(signer)))
            }
            Err(r) => {
                // Never a candidate again; were this lost, boot would find it fails to load.
                let _ = self.set_state(slot, REVOKED_AT, REVOKED);
                Err(r)
            }
        }
    }

    /// The transfer into `slot` read back whole and authenticated against `policy`, the
    /// `running` model and the floor: its length, its blob's and its signer.
    #[inline(never)]
    fn authentic(
        &mut self,
        policy: &Policy,
        running: &ModelInfo,
        slot: usize,
    ) -> Result<(usize, usize, Signer), Rejection> {
        let total = self.staging.finish(&mut self.flash)?;
        let file = self.flash.sector(slot).get(PAYLOAD_AT..PAYLOAD_AT + total).unwrap_or(&[]);
        let (blob, signer) = authenticate(policy, file, Some(running))?;
        // Below the floor while a model below it runs (the embedded default, after the slots
        // failed at boot): that would be a rollback.
        let floor = self.floor();
        if signer.serial < floor && running.serial < floor {
            return Err(SignatureError::Rollback { serial: signer.serial, running: floor }.into());
        }
        Ok((total, blob.len(), signer))
    }

    /// Make `slot` (its `total`-byte file authenticated) the newest boot candidate: its header
    /// (read back), COMPLETE, then ACTIVE, the one word written last.
    #[inline(never)]
    fn activate(
        &mut self,
        slot: usize,
        total: usize,
        blob_len: usize,
        signer: Signer,
    ) -> Result<SlotHeader, Rejection> {
        let file = self.flash.sector(slot).get(PAYLOAD_AT..PAYLOAD_AT + blob_len).unwrap_or(&[]);
        let digest = stored_crc(file).unwrap_or(0);
        let generation = self.generation(0).max(self.generation(1)).wrapping_add(1);
        let len = u32::try_from(total).unwrap_or(u32::MAX);
        let header = SlotHeader { generation, len, digest, serial: signer.serial, key_id: signer.key_id };
        let base = slot * F::ERASE_SIZE;
        self.program(base + SLOT_HEADER_AT, &header.to_bytes()).map_err(|_| storage(base + SLOT_HEADER_AT))?;
        self.set_state(slot, COMPLETE_AT, COMPLETE).map_err(|_| storage(base + COMPLETE_AT))?;
        self.set_state(slot, ACTIVE_AT, ACTIVE).map_err(|_| storage(base + ACTIVE_AT))?;
        Ok(header)
    }

    /// Log the refusal `r` of the transfer of `total` bytes into `slot`, naming what its bytes
    /// claim to be (unverified: an audit hint), or count it unlogged beyond the budget.
    #[inline(never)]
    fn log_refusal(&mut self, r: Rejection, slot: usize, total: usize) {
        if u32::from(self.refusals_since_accept) >= REFUSALS_LOGGED {
            self.refusals_unlogged = self.refusals_unlogged.wrapping_add(1);
            return;
        }
        self.refusals_since_accept += 1;
        let file = self.flash.sector(slot).get(PAYLOAD_AT..PAYLOAD_AT + total).unwrap_or(&[]);
        let (serial, key_id, digest) = match container::open(file) {
            Ok(Envelope::Signed(s)) => (s.head.serial, s.head.key_id, stored_crc(s.blob).unwrap_or(0)),
            _ => (0, KeyId::default(), stored_crc(file).unwrap_or(0)),
        };
        let rec = Record {
            kind: EventKind::Refused,
            reason: r.reason.code(),
            flags: 0,
            slot: 0xFF,
            event: 0,
            serial,
            key_id,
            digest,
            detail: r.detail,
            generation: 0,
        };
        if self.append(rec).is_err() {
            self.refusals_unlogged = self.refusals_unlogged.wrapping_add(1);
        }
    }
}

/// The refusal of a failed erase or program at store offset `at`.
fn storage(at: usize) -> Rejection {
    Rejection { reason: RejectReason::Storage, detail: u32::try_from(at).unwrap_or(u32::MAX) }
}

/* fmu_src/native/fmu_state.h: the FMU state of every native ballmill FMU, its layout, its
 * checksum and its check, written once for the FMI plumbing of every FMI version (fmi2.c
 * calls these functions; the plumbing of another FMI version calls the same ones with its
 * own version number and instance states).
 *
 * A state is one block of bytes, the same in memory (fmi2GetFMUstate) and serialised
 * (fmi2SerializeFMUstate), for the machine and build that wrote it:
 *
 *   offset  bytes  what
 *   0       160    fmu_state_header: magic "ballmill", format FMU_STATE_FORMAT, the FMI
 *                  version of the plumbing that wrote it (its instance-state numbers),
 *                  n_vars, the instance state (one bit), data size, total size, model
 *                  identifier and GUID (NUL padded), built flag, reserved 0, t_start, t
 *   160     8 n    the values v[] by value reference (n = n_vars)
 *   ...     d      the model's data (d = data_size): configuration, then dynamic state
 *   end-4   4      CRC-32 (IEEE 802.3, as zlib.crc32) of every byte before it, stored
 *                  little-endian
 *
 * The checksum is computed when a state is serialised and checked when one is
 * deserialised; fmi2GetFMUstate leaves it 0 and fmi2SetFMUstate does not read it (the
 * states of a rollback loop stay in memory and do not pay for it: the checksum of
 * BallInShell's 12 kB state took 0.13 ms, copying it 0.2 us, measured side by side on a
 * loaded 2-core machine). Any byte changed in a serialised state is refused, the reason
 * naming what failed.
 */
#ifndef BALLMILL_FMU_STATE_H
#define BALLMILL_FMU_STATE_H

#include <stddef.h>
#include <stdint.h>

#define FMU_STATE_MAGIC "ballmill"
#define FMU_STATE_FORMAT 5u /* 4: BallInShell's hybrid bookkeeping without the hold (t_held, held_window); 3: BallInShell's hybrid states without the torque quadrature Lq; 2: BallInShell's data without the hybrid ball's mode and bookkeeping; 1: no checksum, no FMI version field */
#define FMU_STATE_WHY 320   /* room for the reason a state is refused */

typedef struct {
    char magic[8];
    uint32_t format;
    uint32_t fmi;     /* FMI major version of the plumbing that wrote the state */
    uint32_t n_vars;
    int32_t phase;    /* the plumbing's instance state: one bit of its enum */
    uint64_t data_size;
    uint64_t total_size;
    char identifier[32];
    char guid[64];
    int32_t built;    /* 1 when the model's setup had run (the data hold a configuration) */
    uint32_t reserved;
    double t_start, t;
} fmu_state_header;

/* bytes of a state of this FMU (FMU_MODEL), checksum included */
size_t fmu_state_size(void);

/* write a state of this FMU into blob (fmu_state_size() bytes), checksum 0 */
void fmu_state_write(unsigned char *blob, uint32_t fmi, int32_t phase, int built, double t_start, double t,
                     const double *v, const unsigned char *data);

/* the parts of a state that fmu_state_check accepted */
void fmu_state_header_of(const unsigned char *blob, fmu_state_header *h);
const double *fmu_state_values(const unsigned char *blob);
const unsigned char *fmu_state_data(const unsigned char *blob);

/* 0 when blob (size bytes) is a state of this FMU written by the plumbing of FMI version
 * fmi, in one of the instance states whose bits are in phases, with its checksum checked
 * when sealed (a serialised state); else 1 with the reason in why, e.g. "checksum
 * mismatch: stored 0x..., computed 0x...", "format version 2, expected 3", "model
 * 'MotorStartup', expected 'BallInShell'", "size 12329, expected 12328" */
int fmu_state_check(const unsigned char *blob, size_t size, uint32_t fmi, int32_t phases, int sealed,
                    char why[FMU_STATE_WHY]);

/* compute the checksum of a state of fmu_state_size() bytes and store it in its last 4 */
void fmu_state_seal(unsigned char *blob);

/* CRC-32 (IEEE 802.3, reflected polynomial 0xEDB88320: zlib.crc32's) of n bytes */
uint32_t fmu_crc32(const unsigned char *bytes, size_t n);

#endif

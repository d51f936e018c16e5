/* fmu_src/native/fmu_state.c: the FMU state's layout, checksum and check (fmu_state.h). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "fmu_model.h"
#include "fmu_state.h"

_Static_assert(sizeof(fmu_state_header) == 160, "the header has no padding: every byte is a field");

#define CHECKSUM_BYTES 4u

size_t fmu_state_size(void)
{
    return sizeof(fmu_state_header) + (size_t)FMU_MODEL.n_vars * sizeof(double) + FMU_MODEL.data_size
           + CHECKSUM_BYTES;
}

/* the header of a state of this FMU, its instance state and times left 0 */
static void identity(fmu_state_header *h, uint32_t fmi)
{
    memset(h, 0, sizeof *h);
    memcpy(h->magic, FMU_STATE_MAGIC, sizeof h->magic);
    h->format = FMU_STATE_FORMAT;
    h->fmi = fmi;
    h->n_vars = (uint32_t)FMU_MODEL.n_vars;
    h->data_size = FMU_MODEL.data_size;
    h->total_size = fmu_state_size();
    strncpy(h->identifier, FMU_MODEL.identifier, sizeof h->identifier - 1);
    strncpy(h->guid, FMU_MODEL.guid, sizeof h->guid - 1);
}

void fmu_state_write(unsigned char *blob, uint32_t fmi, int32_t phase, int built, double t_start, double t,
                     const double *v, const unsigned char *data)
{
    fmu_state_header h;
    identity(&h, fmi);
    h.phase = phase;
    h.built = built ? 1 : 0;
    h.t_start = t_start;
    h.t = t;
    size_t nv = (size_t)FMU_MODEL.n_vars * sizeof(double);
    memcpy(blob, &h, sizeof h);
    memcpy(blob + sizeof h, v, nv);
    memcpy(blob + sizeof h + nv, data, FMU_MODEL.data_size);
    memset(blob + sizeof h + nv + FMU_MODEL.data_size, 0, CHECKSUM_BYTES);
}

void fmu_state_header_of(const unsigned char *blob, fmu_state_header *h) { memcpy(h, blob, sizeof *h); }

const double *fmu_state_values(const unsigned char *blob)
{
    return (const double *)(const void *)(blob + sizeof(fmu_state_header));
}

const unsigned char *fmu_state_data(const unsigned char *blob)
{
    return blob + sizeof(fmu_state_header) + (size_t)FMU_MODEL.n_vars * sizeof(double);
}

/* CRC-32 four bits at a time: the 16 remainders of the reflected polynomial 0xEDB88320 */
uint32_t fmu_crc32(const unsigned char *bytes, size_t n)
{
    static const uint32_t nibble[16] = {
        0x00000000u, 0x1DB71064u, 0x3B6E20C8u, 0x26D930ACu, 0x76DC4190u, 0x6B6B51F4u, 0x4DB26158u, 0x5005713Cu,
        0xEDB88320u, 0xF00F9344u, 0xD6D6A3E8u, 0xCB61B38Cu, 0x9B64C2B0u, 0x86D3D2D4u, 0xA00AE278u, 0xBDBDF21Cu};
    uint32_t crc = 0xFFFFFFFFu;
    for (size_t i = 0; i < n; i++) {
        crc ^= bytes[i];
        crc = (crc >> 4) ^ nibble[crc & 15u];
        crc = (crc >> 4) ^ nibble[crc & 15u];
    }
    return crc ^ 0xFFFFFFFFu;
}

static uint32_t stored_checksum(const unsigned char *end)
{
    return (uint32_t)end[0] | (uint32_t)end[1] << 8 | (uint32_t)end[2] << 16 | (uint32_t)end[3] << 24;
}

void fmu_state_seal(unsigned char *blob)
{
    size_t n = fmu_state_size() - CHECKSUM_BYTES;
    uint32_t crc = fmu_crc32(blob, n);
    for (unsigned k = 0; k < CHECKSUM_BYTES; k++) blob[n + k] = (unsigned char)(crc >> (8 * k));
}

/* a fixed-size text field of a header for a message: up to its first NUL, anything but
 * printable ASCII as '?' */
static const char *shown(char *out, const char *field, size_t n)
{
    size_t i = 0;
    for (; i < n && field[i]; i++) out[i] = field[i] >= 0x20 && field[i] < 0x7f ? field[i] : '?';
    out[i] = '\0';
    return out;
}

int fmu_state_check(const unsigned char *blob, size_t size, uint32_t fmi, int32_t phases, int sealed,
                    char why[FMU_STATE_WHY])
{
    fmu_state_header h, ref;
    char a[65], b[65];
    why[0] = '\0';
    if (!blob) {
        snprintf(why, FMU_STATE_WHY, "no state given (NULL)");
        return 1;
    }
    if (size < sizeof h + CHECKSUM_BYTES) {
        snprintf(why, FMU_STATE_WHY, "size %zu, shorter than a state header and its checksum (%zu bytes)", size,
                 sizeof h + CHECKSUM_BYTES);
        return 1;
    }
    memcpy(&h, blob, sizeof h);
    identity(&ref, fmi);
    if (memcmp(h.magic, ref.magic, sizeof h.magic) != 0) {
        snprintf(why, FMU_STATE_WHY, "magic '%s', expected '%s': not a ballmill FMU state",
                 shown(a, h.magic, sizeof h.magic), FMU_STATE_MAGIC);
        return 1;
    }
    if (h.format != ref.format) {
        snprintf(why, FMU_STATE_WHY, "format version %u, expected %u", (unsigned)h.format, (unsigned)ref.format);
        return 1;
    }
    if (h.fmi != ref.fmi) {
        snprintf(why, FMU_STATE_WHY, "written by the FMI %u plumbing, expected FMI %u", (unsigned)h.fmi,
                 (unsigned)ref.fmi);
        return 1;
    }
    if (h.total_size != size) { /* the checksum's place depends on it */
        snprintf(why, FMU_STATE_WHY, "size %zu, expected %llu (the size its header gives)", size,
                 (unsigned long long)h.total_size);
        return 1;
    }
    if (sealed) {
        uint32_t stored = stored_checksum(blob + size - CHECKSUM_BYTES);
        uint32_t computed = fmu_crc32(blob, size - CHECKSUM_BYTES);
        if (stored != computed) {
            snprintf(why, FMU_STATE_WHY, "checksum mismatch: stored 0x%08x, computed 0x%08x (the state was changed "
                     "after it was serialised)", (unsigned)stored, (unsigned)computed);
            return 1;
        }
    }
    if (memcmp(h.identifier, ref.identifier, sizeof h.identifier) != 0) {
        snprintf(why, FMU_STATE_WHY, "model '%s', expected '%s'", shown(a, h.identifier, sizeof h.identifier),
                 ref.identifier);
        return 1;
    }
    if (memcmp(h.guid, ref.guid, sizeof h.guid) != 0) {
        snprintf(why, FMU_STATE_WHY, "GUID '%s', expected '%s': a state of another build of this model",
                 shown(a, h.guid, sizeof h.guid), shown(b, ref.guid, sizeof ref.guid));
        return 1;
    }
    if (h.n_vars != ref.n_vars || h.data_size != ref.data_size || h.total_size != ref.total_size) {
        snprintf(why, FMU_STATE_WHY, "size %llu (%u values, %llu bytes of model data), expected %llu (%u values, "
                 "%llu bytes)", (unsigned long long)h.total_size, (unsigned)h.n_vars, (unsigned long long)h.data_size,
                 (unsigned long long)ref.total_size, (unsigned)ref.n_vars, (unsigned long long)ref.data_size);
        return 1;
    }
    if (!(h.phase > 0 && (h.phase & (h.phase - 1)) == 0 && (h.phase & phases))) {
        snprintf(why, FMU_STATE_WHY, "instance state %d, expected one a state can be taken in", (int)h.phase);
        return 1;
    }
    if (!(h.built == 0 || h.built == 1) || h.reserved != 0) {
        snprintf(why, FMU_STATE_WHY, "built flag %d and reserved field %u, expected 0 or 1 and 0", (int)h.built,
                 (unsigned)h.reserved);
        return 1;
    }
    if (!(isfinite(h.t_start) && isfinite(h.t))) {
        snprintf(why, FMU_STATE_WHY, "times t_start = %s s and t = %s s, expected finite", fmu_repr(h.t_start, a),
                 fmu_repr(h.t, b));
        return 1;
    }
    return 0;
}

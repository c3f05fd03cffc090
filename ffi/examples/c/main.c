/*
 * The dynotraj edge driven from C: reads a recorded link byte stream (wire frames from the
 * host), feeds it to a session in 256-byte chunks as a UART driver would, and writes every
 * reply frame the session emits to a file, byte for byte what would go back to the host.
 *
 *   dynotraj-c [STREAM [REPLIES]]     (defaults: stream.bin, replies.bin)
 *
 * The same file runs on the host and, under QEMU mps2-an386, on a Cortex-M4F, where newlib's
 * semihosting opens the host's files.
 */
#include <stdint.h>
#include <stdio.h>

#include "dynotraj.h"

/* The session lives in static memory: about 100 KiB, too much for most ECU stacks. */
static _Alignas(DYNOTRAJ_SESSION_ALIGN) unsigned char session_memory[DYNOTRAJ_SESSION_SIZE];

struct replies {
    FILE *file;
    unsigned long frames;
    unsigned long bytes;
};

/* The write callback: one encoded wire frame per call, forwarded as is. */
static int32_t write_frame(void *ctx, const uint8_t *frame, size_t len) {
    struct replies *out = ctx;
    if (fwrite(frame, 1, len, out->file) != len) {
        return -1;
    }
    out->frames += 1;
    out->bytes += len;
    return 0;
}

int main(int argc, char **argv) {
    const char *stream_path = argc > 1 ? argv[1] : "stream.bin";
    const char *replies_path = argc > 2 ? argv[2] : "replies.bin";
    FILE *in = fopen(stream_path, "rb");
    if (in == NULL) {
        fprintf(stderr, "dynotraj-c: cannot open %s\n", stream_path);
        return 2;
    }
    struct replies out = {fopen(replies_path, "wb"), 0, 0};
    if (out.file == NULL) {
        fprintf(stderr, "dynotraj-c: cannot create %s\n", replies_path);
        return 2;
    }

    /* No clock: every frame reports zero compute, so the replies can be compared byte for
     * byte with another build's. An ECU passes its cycle counter and DYNOTRAJ_UNIT_INSTRUCTIONS. */
    const DynotrajConfig config = {
        .write = write_frame,
        .write_ctx = &out,
        .clock = NULL,
        .clock_ctx = NULL,
        .clock_unit = DYNOTRAJ_UNIT_NANOSECONDS,
    };
    DynotrajSession *session = (DynotrajSession *)session_memory;
    DynotrajStatus status = dynotraj_session_init(session, &config);

    uint8_t chunk[256];
    size_t n;
    while (status == DYNOTRAJ_STATUS_OK && (n = fread(chunk, 1, sizeof chunk, in)) > 0) {
        status = dynotraj_session_feed(session, chunk, n, 0);
    }
    if (status == DYNOTRAJ_STATUS_OK || status == DYNOTRAJ_STATUS_ENDED) {
        status = dynotraj_session_finish(session);
    }
    fclose(in);
    if (fclose(out.file) != 0 && status == DYNOTRAJ_STATUS_OK) {
        status = DYNOTRAJ_STATUS_WRITE_FAILED;
    }
    fprintf(stderr, "dynotraj-c: %lu frames, %lu bytes replied; status %d\n", out.frames, out.bytes, (int)status);
    return status == DYNOTRAJ_STATUS_OK ? 0 : 1;
}

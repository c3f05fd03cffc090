/* dynotraj: the edge session for ECU code written in C (ffi/README.md). */

#ifndef DYNOTRAJ_H
#define DYNOTRAJ_H

/* Generated from ffi/src/lib.rs by scripts/gen-header.sh (cbindgen); do not edit. */

#include <stddef.h>
#include <stdint.h>
#if UINTPTR_MAX == 0xFFFFFFFFu
#define DYNOTRAJ_POINTER_32
#elif UINTPTR_MAX == 0xFFFFFFFFFFFFFFFFu
#define DYNOTRAJ_POINTER_64
#else
#error "dynotraj: a target with 32- or 64-bit pointers is needed"
#endif

#if defined(DYNOTRAJ_POINTER_32)
// Bytes of a `DynotrajSession` on targets with 32-bit pointers (Cortex-M).
#define DYNOTRAJ_SESSION_SIZE 107248
#endif

#if defined(DYNOTRAJ_POINTER_64)
// Bytes of a `DynotrajSession` on targets with 64-bit pointers (the host).
#define DYNOTRAJ_SESSION_SIZE 108488
#endif

// Alignment a `DynotrajSession`'s memory must have, bytes.
#define DYNOTRAJ_SESSION_ALIGN 8

// `DynotrajConfig::clock_unit`: the clock counts nanoseconds.
#define DYNOTRAJ_UNIT_NANOSECONDS 0

// `DynotrajConfig::clock_unit`: the clock counts instructions or cycles (a cycle counter
// such as the Cortex-M DWT's CYCCNT).
#define DYNOTRAJ_UNIT_INSTRUCTIONS 1

// What a call did.
typedef enum DynotrajStatus {
  // Done.
  DYNOTRAJ_STATUS_OK = 0,
  // The host said goodbye: every byte before it was taken and answered, the rest of the
  // chunk was not. Not an error: call `dynotraj_session_finish` next.
  DYNOTRAJ_STATUS_ENDED = 1,
  // A pointer that must not be null was null (a zero length allows a null buffer).
  DYNOTRAJ_STATUS_NULL_POINTER = 2,
  // The session's memory is not aligned to `DYNOTRAJ_SESSION_ALIGN`, or the configuration
  // not to its own type.
  DYNOTRAJ_STATUS_MISALIGNED = 3,
  // An argument is out of range: an unknown clock unit, or a length over `PTRDIFF_MAX`.
  DYNOTRAJ_STATUS_INVALID_ARGUMENT = 4,
  // The write callback returned non-zero. The reply it was given and the rest of the chunk
  // were dropped; the session stays consistent and takes the next chunk.
  DYNOTRAJ_STATUS_WRITE_FAILED = 5,
  // A reply could not be encoded (no wire message is larger than a frame, so this is not
  // expected); the rest of the chunk was dropped.
  DYNOTRAJ_STATUS_ENCODE_FAILED = 6,
  // The model blob is not a valid blob for this build; the previous model stays in use.
  DYNOTRAJ_STATUS_INVALID_MODEL = 7,
} DynotrajStatus;

// One edge session in caller-owned memory: opaque to C, which allocates
// `DYNOTRAJ_SESSION_SIZE` bytes aligned to `DYNOTRAJ_SESSION_ALIGN` and passes a pointer.
typedef struct DynotrajSession DynotrajSession;

// Sends one encoded wire frame (`frame`, `len` bytes, delimiters included) to the host;
// returns 0 when it was sent, anything else when it could not be. `frame` is valid only during
// the call.
typedef int32_t (*DynotrajWriteFn)(void *ctx, const uint8_t *frame, size_t len);

// Reads a monotonic counter (nanoseconds or instructions, see `DynotrajConfig::clock_unit`);
// the session reports the difference around each frame's work as that frame's compute.
typedef uint64_t (*DynotrajClockFn)(void *ctx);

// How the session reaches its platform; copied by `dynotraj_session_init`.
typedef struct DynotrajConfig {
  // Where replies go; required.
  DynotrajWriteFn write;
  // Passed to `write` as is.
  void *write_ctx;
  // The compute clock; null reports zero compute for every frame (outputs that must match
  // another build byte for byte).
  DynotrajClockFn clock;
  // Passed to `clock` as is.
  void *clock_ctx;
  // `DYNOTRAJ_UNIT_NANOSECONDS` or `DYNOTRAJ_UNIT_INSTRUCTIONS`: what one count of `clock`
  // is, as the host is told.
  uint32_t clock_unit;
} DynotrajConfig;

#ifdef __cplusplus
extern "C" {
#endif // __cplusplus

// Initialises a session in `session`'s memory with `config`'s callbacks: no camera model yet,
// no learned model (constant-velocity forecasts), models over the link refused. Also starts a
// used session afresh (its model is dropped).
//
// # Safety
// - `session` points to `DYNOTRAJ_SESSION_SIZE` writable bytes that no other call uses
//   meanwhile; what they held is overwritten, not dropped.
// - `config` points to a readable `DynotrajConfig`, whose `write` (and `clock`, when not
//   null) may be called with its context from any later call on this session until it is
//   initialised again.
// - The stack has room for one session (about 100 KiB) beside the caller's frames.
enum DynotrajStatus dynotraj_session_init(struct DynotrajSession *session,
                                          const struct DynotrajConfig *config);

// Forecasts the agents of the model blob's dynamics (vehicles and cyclists: unicycle;
// pedestrians: single integrator) with `blob` (`len` bytes, int8 or f32) from now on, instead
// of constant velocity. Call once per agent type; a blob of a type already set replaces it.
//
// # Safety
// - `session` was initialised by `dynotraj_session_init` and no other call uses it meanwhile.
// - `blob` points to `len` readable bytes that stay valid and unchanged until the session is
//   initialised again or given another model (normally a blob in flash).
enum DynotrajStatus dynotraj_session_set_model(struct DynotrajSession *session,
                                               const uint8_t *blob,
                                               size_t len);

// Takes `len` received bytes (any split of the stream: frames may span calls) and answers
// every whole message in them, each reply a call of the write callback before this returns.
// `bytes_lost` is how many bytes the caller's receiver dropped so far (overruns), reported to
// the host with the decoder's own drops; 0 when it cannot lose bytes.
//
// Returns `DYNOTRAJ_STATUS_ENDED` once the host said goodbye (and for every call after).
//
// # Safety
// - `session` was initialised by `dynotraj_session_init` and no other call uses it meanwhile.
// - `bytes` points to `len` readable bytes (or is anything when `len` is 0).
enum DynotrajStatus dynotraj_session_feed(struct DynotrajSession *session,
                                          const uint8_t *bytes,
                                          size_t len,
                                          uint32_t bytes_lost);

// Ends the session's stream: unless the host said goodbye, an unfinished frame's bytes are
// counted as dropped; then the edge's link statistics go out through the write callback (the
// session's last reply). Initialise the session again before another stream.
//
// # Safety
// `session` was initialised by `dynotraj_session_init` and no other call uses it meanwhile.
enum DynotrajStatus dynotraj_session_finish(struct DynotrajSession *session);

#ifdef __cplusplus
}  // extern "C"
#endif  // __cplusplus

#endif  /* DYNOTRAJ_H */

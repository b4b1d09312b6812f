/*
 * haptic6d in a device servo loop, in C.
 *
 * A haptic device's SDK calls a callback once per servo tick (1 kHz): read the handle's pose,
 * compute the wrench, send it. `servo_tick` below is that callback; the device here is
 * simulated: it replays a recorded trajectory CSV (t,x,y,z,gamma,beta,alpha; mm and rad) one
 * row per tick, and "sends" each wrench by writing a CSV row on stdout.
 *
 *   cargo build --release -p haptic6d-capi
 *   cc -O2 -Icrates/capi/include examples/c/servo_loop.c target/release/libhaptic6d.a \
 *      -lpthread -ldl -lm -o servo_loop
 *   ./servo_loop bunny runs/bunny/trajectory.csv > wrench.csv
 *
 * Usage: servo_loop SCENE TRAJECTORY.csv [BUDGET_US]
 *   SCENE       a built-in scene (bunny, spline, plate, spline-tight, probe) or a scene
 *               file (.toml)
 *   BUDGET_US   the frame's time budget, µs (default: the scene's)
 * Output (stdout): t,fx,fy,fz,tx,ty,tz,xg,yg,zg,gg,bg,ag,status (s, N, N·mm, mm, rad).
 */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "haptic6d.h"

/* One recorded device sample: time (s) and pose [x, y, z, gamma, beta, alpha] (mm, rad). */
typedef struct {
    double t;
    double q[6];
} Sample;

/* The simulated device: a recording replayed one sample per tick, and where wrenches go. */
typedef struct {
    Sample *samples;
    size_t count;
    size_t next;
    FILE *out;
} SimDevice;

/* Reads the CSV written by `haptic6d run` (trajectory.csv) or any recorder; 0 on success. */
static int device_open(SimDevice *dev, const char *path, FILE *out) {
    FILE *f = fopen(path, "r");
    if (!f) {
        fprintf(stderr, "servo_loop: cannot open %s: %s\n", path, strerror(errno));
        return 1;
    }
    char line[1024];
    size_t cap = 1024;
    dev->samples = malloc(cap * sizeof(Sample));
    dev->count = 0;
    dev->next = 0;
    dev->out = out;
    if (!dev->samples || !fgets(line, sizeof line, f) || strncmp(line, "t,x,y,z,gamma,beta,alpha", 24) != 0) {
        fprintf(stderr, "servo_loop: %s: expected the header t,x,y,z,gamma,beta,alpha\n", path);
        fclose(f);
        return 1;
    }
    size_t lineno = 1;
    while (fgets(line, sizeof line, f)) {
        lineno++;
        if (line[0] == '\n' || line[0] == '#') {
            continue;
        }
        if (dev->count == cap) {
            cap *= 2;
            Sample *grown = realloc(dev->samples, cap * sizeof(Sample));
            if (!grown) {
                fprintf(stderr, "servo_loop: out of memory reading %s\n", path);
                fclose(f);
                return 1;
            }
            dev->samples = grown;
        }
        Sample *s = &dev->samples[dev->count];
        double v[7];
        char *p = line;
        for (int i = 0; i < 7; i++) {
            char *end;
            v[i] = strtod(p, &end);
            if (end == p || (i < 6 && *end != ',')) {
                fprintf(stderr, "servo_loop: %s:%zu: expected 7 numbers t,x,y,z,gamma,beta,alpha\n", path, lineno);
                fclose(f);
                return 1;
            }
            p = end + 1;
        }
        s->t = v[0];
        memcpy(s->q, v + 1, sizeof s->q);
        dev->count++;
    }
    fclose(f);
    if (dev->count == 0) {
        fprintf(stderr, "servo_loop: %s: no samples\n", path);
        return 1;
    }
    return 0;
}

/* The device's pose now; 0 when the recording has ended. */
static int device_read_pose(SimDevice *dev, double *t, double q[6]) {
    if (dev->next >= dev->count) {
        return 0;
    }
    *t = dev->samples[dev->next].t;
    memcpy(q, dev->samples[dev->next].q, 6 * sizeof(double));
    dev->next++;
    return 1;
}

/* Sends the wrench to the (simulated) motors: one CSV row, full precision. */
static void device_write_wrench(SimDevice *dev, double t, const double wrench[6], const double q_g[6],
                                uint32_t frame_status) {
    fprintf(dev->out, "%.17g", t);
    for (int i = 0; i < 6; i++) fprintf(dev->out, ",%.17g", wrench[i]);
    for (int i = 0; i < 6; i++) fprintf(dev->out, ",%.17g", q_g[i]);
    fprintf(dev->out, ",%u\n", frame_status);
}

/* What the servo callback needs, set up before the loop starts. */
typedef struct {
    H6dEngine *engine;
    SimDevice *device;
    double rate_hz;
    uint64_t frame;
} Servo;

/*
 * The 1 kHz servo callback: pose in, wrench out. Returns 1 to be called again, 0 to stop
 * (the recording ended, or the engine failed). Nothing here allocates or blocks.
 */
static int servo_tick(void *user) {
    Servo *s = (Servo *)user;
    double t_device, q_h[6], wrench[6], q_g[6];
    H6dFrameInfo info;
    if (!device_read_pose(s->device, &t_device, q_h)) {
        return 0;
    }
    /* The engine's clock: frame / rate, as `haptic6d run` steps a recording. */
    double t = (double)s->frame / s->rate_hz;
    int32_t status = h6d_engine_step(s->engine, t, q_h, wrench, q_g, &info);
    if (status == H6D_STATUS_INVALID_ARGUMENT) {
        /* A NaN pose from the device: the engine kept the last safe pose; the wrench written
         * is safe to send. Say so and carry on, as a device loop must. */
        fprintf(stderr, "servo_loop: frame %llu: %s\n", (unsigned long long)s->frame, h6d_last_error_message());
    } else if (status != H6D_STATUS_OK) {
        fprintf(stderr, "servo_loop: frame %llu: %s\n", (unsigned long long)s->frame, h6d_last_error_message());
        return 0;
    }
    device_write_wrench(s->device, t_device, wrench, q_g, info.status);
    s->frame++;
    return 1;
}

static int fail(const char *what) {
    fprintf(stderr, "servo_loop: %s: %s\n", what, h6d_last_error_message());
    return 1;
}

int main(int argc, char **argv) {
    if (argc < 3 || argc > 4) {
        fprintf(stderr, "usage: %s SCENE TRAJECTORY.csv [BUDGET_US]\n", argv[0]);
        return 2;
    }
    SimDevice device;
    if (device_open(&device, argv[2], stdout) != 0) {
        return 1;
    }

    /* Set-up (allocates, may build trees): before the loop. */
    H6dScene *scene = NULL;
    if (h6d_scene_load(argv[1], &scene) != H6D_STATUS_OK) {
        free(device.samples);
        return fail("loading the scene");
    }
    H6dConfig config;
    double rate_hz;
    if (h6d_scene_config(scene, &config) != H6D_STATUS_OK || h6d_scene_rate_hz(scene, &rate_hz) != H6D_STATUS_OK) {
        h6d_scene_destroy(scene);
        free(device.samples);
        return fail("reading the scene");
    }
    if (argc == 4) {
        config.budget_us = strtod(argv[3], NULL);
    }
    H6dEngine *engine = NULL;
    int32_t made = h6d_scene_engine(scene, &config, &engine);
    h6d_scene_destroy(scene); /* the engine owns its trees */
    if (made != H6D_STATUS_OK) {
        free(device.samples);
        return fail("making the engine");
    }
    /* The run starts with the tool where the device is. */
    if (h6d_engine_reset(engine, device.samples[0].q, NULL) != H6D_STATUS_OK) {
        h6d_engine_destroy(engine);
        free(device.samples);
        return fail("resetting the engine");
    }

    /* The loop: a real device's scheduler calls servo_tick every millisecond. */
    Servo servo = {engine, &device, rate_hz, 0};
    printf("t,fx,fy,fz,tx,ty,tz,xg,yg,zg,gg,bg,ag,status\n");
    while (servo_tick(&servo)) {
    }
    int ended = device.next == device.count && servo.frame == device.count;

    H6dCounters counters;
    size_t contacts = 0;
    if (h6d_engine_counters(engine, &counters) == H6D_STATUS_OK &&
        h6d_engine_contacts(engine, NULL, 0, &contacts) != H6D_STATUS_PANIC) {
        fprintf(stderr, "servo_loop: %llu frames; %llu lagging, %llu kept-last-safe; %llu force clamps; %zu pairs in the last region\n",
                (unsigned long long)counters.frames, (unsigned long long)counters.lagging,
                (unsigned long long)counters.kept_last_safe, (unsigned long long)counters.force_clamps, contacts);
    }
    h6d_engine_destroy(engine);
    free(device.samples);
    return ended ? 0 : 1;
}

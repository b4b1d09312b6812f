// haptic6d in a device servo loop, in C++: the C API behind small RAII classes (a handle is
// freed by its owner's destructor; a failed call throws h6d::Error with the library's message).
//
// The same program as examples/c/servo_loop.c: a simulated device replays a trajectory CSV
// (t,x,y,z,gamma,beta,alpha; mm and rad) one row per servo tick, and each wrench "sent" is a
// CSV row on stdout.
//
//   cargo build --release -p haptic6d-capi
//   c++ -std=c++17 -O2 -Icrates/capi/include examples/cpp/servo_loop.cpp
//       target/release/libhaptic6d.a -lpthread -ldl -lm -o servo_loop_cpp
//   ./servo_loop_cpp bunny runs/bunny/trajectory.csv > wrench.csv
//
// Usage: servo_loop_cpp SCENE TRAJECTORY.csv [BUDGET_US]
// Output (stdout): t,fx,fy,fz,tx,ty,tz,xg,yg,zg,gg,bg,ag,status (s, N, N·mm, mm, rad).
#include <array>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "haptic6d.h"

namespace h6d {

// A failed call: the status and the library's one-line message.
class Error : public std::runtime_error {
  public:
    Error(int32_t status, const std::string &message) : std::runtime_error(message), status_(status) {}
    int32_t status() const { return status_; }

  private:
    int32_t status_;
};

// Throws on anything but success.
inline void check(int32_t status) {
    if (status != H6D_STATUS_OK) {
        throw Error(status, h6d_last_error_message());
    }
}

using Pose = std::array<double, 6>;  // [x, y, z, gamma, beta, alpha]: mm, rad

// A loaded scene (built-in name or .toml file); read-only.
class Scene {
  public:
    explicit Scene(const std::string &name) {
        H6dScene *raw = nullptr;
        check(h6d_scene_load(name.c_str(), &raw));
        handle_.reset(raw);
    }
    H6dConfig config() const {
        H6dConfig c;
        check(h6d_scene_config(handle_.get(), &c));
        return c;
    }
    double rate_hz() const {
        double r = 0.0;
        check(h6d_scene_rate_hz(handle_.get(), &r));
        return r;
    }
    const H6dScene *get() const { return handle_.get(); }

  private:
    struct Free {
        void operator()(H6dScene *s) const { h6d_scene_destroy(s); }
    };
    std::unique_ptr<H6dScene, Free> handle_;
};

// One frame's outputs.
struct Frame {
    std::array<double, 6> wrench;  // [Fx, Fy, Fz, Tx, Ty, Tz]: N, N·mm
    Pose q_g;                      // graphic tool pose: mm, rad
    H6dFrameInfo info;
    bool input_finite;  // false: the device sent a NaN pose; the wrench is still safe
};

// The engine: owns its handle; movable, not copyable. One thread at a time.
class Engine {
  public:
    Engine(const Scene &scene, const H6dConfig &config) {
        H6dEngine *raw = nullptr;
        check(h6d_scene_engine(scene.get(), &config, &raw));
        handle_.reset(raw);
    }
    Pose reset(const Pose &start) {
        Pose q_g;
        check(h6d_engine_reset(handle_.get(), start.data(), q_g.data()));
        return q_g;
    }
    // One haptic frame. Does not throw for a non-finite device pose (a servo tick must still
    // send the safe wrench the engine wrote); throws for everything else.
    Frame step(double t, const Pose &q_h) {
        Frame f;
        int32_t status = h6d_engine_step(handle_.get(), t, q_h.data(), f.wrench.data(), f.q_g.data(), &f.info);
        f.input_finite = status != H6D_STATUS_INVALID_ARGUMENT;
        if (f.input_finite) {
            check(status);
        }
        return f;
    }
    H6dCounters counters() {
        H6dCounters c;
        check(h6d_engine_counters(handle_.get(), &c));
        return c;
    }
    std::vector<H6dContact> contacts() {
        size_t n = 0;
        int32_t status = h6d_engine_contacts(handle_.get(), nullptr, 0, &n);
        if (status != H6D_STATUS_BUFFER_TOO_SMALL) {
            check(status);
        }
        std::vector<H6dContact> out(n);
        check(h6d_engine_contacts(handle_.get(), out.data(), out.size(), &n));
        return out;
    }

  private:
    struct Free {
        void operator()(H6dEngine *e) const { h6d_engine_destroy(e); }
    };
    std::unique_ptr<H6dEngine, Free> handle_;
};

}  // namespace h6d

// One recorded device sample: time (s) and pose.
struct Sample {
    double t;
    h6d::Pose q;
};

// The simulated device: a recording replayed one sample per tick.
class SimDevice {
  public:
    explicit SimDevice(const std::string &path) {
        std::ifstream in(path);
        if (!in) throw std::runtime_error("cannot open " + path);
        std::string line;
        if (!std::getline(in, line) || line.rfind("t,x,y,z,gamma,beta,alpha", 0) != 0) {
            throw std::runtime_error(path + ": expected the header t,x,y,z,gamma,beta,alpha");
        }
        size_t lineno = 1;
        while (std::getline(in, line)) {
            lineno++;
            if (line.empty() || line[0] == '#') continue;
            Sample s{};
            const char *p = line.c_str();
            double v[7];
            for (int i = 0; i < 7; i++) {
                char *end = nullptr;
                v[i] = std::strtod(p, &end);
                if (end == p || (i < 6 && *end != ',')) {
                    throw std::runtime_error(path + ":" + std::to_string(lineno) + ": expected 7 numbers t,x,y,z,gamma,beta,alpha");
                }
                p = end + 1;
            }
            s.t = v[0];
            for (int i = 0; i < 6; i++) s.q[i] = v[i + 1];
            samples_.push_back(s);
        }
        if (samples_.empty()) throw std::runtime_error(path + ": no samples");
    }
    const Sample &first() const { return samples_.front(); }
    bool read_pose(double &t, h6d::Pose &q) {
        if (next_ >= samples_.size()) return false;
        t = samples_[next_].t;
        q = samples_[next_].q;
        next_++;
        return true;
    }
    void write_wrench(double t, const h6d::Frame &f) {
        std::printf("%.17g", t);
        for (double w : f.wrench) std::printf(",%.17g", w);
        for (double q : f.q_g) std::printf(",%.17g", q);
        std::printf(",%u\n", f.info.status);
    }

  private:
    std::vector<Sample> samples_;
    size_t next_ = 0;
};

// What the servo callback needs, set up before the loop.
struct Servo {
    h6d::Engine &engine;
    SimDevice &device;
    double rate_hz;
    uint64_t frame = 0;
};

// The 1 kHz servo callback: pose in, wrench out; false to stop (the recording ended).
static bool servo_tick(Servo &s) {
    double t_device;
    h6d::Pose q_h;
    if (!s.device.read_pose(t_device, q_h)) return false;
    // The engine's clock: frame / rate, as `haptic6d run` steps a recording.
    const double t = static_cast<double>(s.frame) / s.rate_hz;
    h6d::Frame f = s.engine.step(t, q_h);
    if (!f.input_finite) {
        std::fprintf(stderr, "servo_loop_cpp: frame %llu: %s\n", static_cast<unsigned long long>(s.frame), h6d_last_error_message());
    }
    s.device.write_wrench(t_device, f);
    s.frame++;
    return true;
}

int main(int argc, char **argv) {
    if (argc < 3 || argc > 4) {
        std::fprintf(stderr, "usage: %s SCENE TRAJECTORY.csv [BUDGET_US]\n", argv[0]);
        return 2;
    }
    try {
        SimDevice device(argv[2]);
        h6d::Scene scene(argv[1]);
        H6dConfig config = scene.config();
        if (argc == 4) config.budget_us = std::strtod(argv[3], nullptr);
        h6d::Engine engine(scene, config);
        engine.reset(device.first().q);
        Servo servo{engine, device, scene.rate_hz()};
        std::printf("t,fx,fy,fz,tx,ty,tz,xg,yg,zg,gg,bg,ag,status\n");
        while (servo_tick(servo)) {
        }
        H6dCounters c = engine.counters();
        std::fprintf(stderr, "servo_loop_cpp: %llu frames; %llu lagging, %llu kept-last-safe; %zu pairs in the last region\n",
                     static_cast<unsigned long long>(c.frames), static_cast<unsigned long long>(c.lagging),
                     static_cast<unsigned long long>(c.kept_last_safe), engine.contacts().size());
    } catch (const h6d::Error &e) {
        std::fprintf(stderr, "servo_loop_cpp: %s (%s)\n", e.what(), h6d_status_name(e.status()));
        return 1;
    } catch (const std::exception &e) {
        std::fprintf(stderr, "servo_loop_cpp: %s\n", e.what());
        return 1;
    }
    return 0;
}

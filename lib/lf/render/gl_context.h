// The EGL/GLES 3 context that lf::GlRenderer draws in (lib/lf/render/
// gl_render.cpp): the EGL display (a device's, else the default one), a
// context of its own per renderer, made current for a scope under one
// lock on a software rasteriser, and the shader compile and link with
// their info logs. Internal to lib/lf/render, not installed; only in
// builds with EGL/GLES (LF_HAVE_GL).
#pragma once
#ifdef LF_HAVE_GL

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GLES3/gl3.h>

#include <cstdio>
#include <cstring>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

namespace lf::gl {

inline bool has_word(const char* list, const char* word) {
  if (!list) return false;
  const size_t n = std::strlen(word);
  for (const char* p = list; (p = std::strstr(p, word)); p += n)
    if ((p == list || p[-1] == ' ') && (p[n] == ' ' || p[n] == '\0')) return true;
  return false;
}

inline bool software_renderer(const std::string& r) {
  for (const char* s : {"llvmpipe", "softpipe", "swrast", "SwiftShader", "lavapipe"})
    if (r.find(s) != std::string::npos) return true;
  return false;
}

inline std::string egl_error(const char* what) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "%s failed (EGL error 0x%04x)", what,
                static_cast<unsigned>(eglGetError()));
  return buf;
}

// An EGL display initialised for GLES, and which platform gave it.
struct Display {
  EGLDisplay dpy = EGL_NO_DISPLAY;
  std::string platform, error;
};

// Picks and initialises the display once per process (see the header for
// the order); EGL displays are process-wide and never terminated here, as
// other users of EGL in the process may share them.
inline const Display& display() {
  static const Display d = [] {
    Display r;
    const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    auto get_platform = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
        eglGetProcAddress("eglGetPlatformDisplayEXT"));
    auto try_init = [&](EGLDisplay dpy, const char* name) {
      EGLint major = 0, minor = 0;
      if (dpy == EGL_NO_DISPLAY || !eglInitialize(dpy, &major, &minor)) return false;
      r.dpy = dpy;
      r.platform = name;
      return true;
    };
    if (!std::getenv("EGL_PLATFORM") && get_platform) {
      if (has_word(client, "EGL_EXT_platform_device")) {
        auto query_devices =
            reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
        auto device_string = reinterpret_cast<PFNEGLQUERYDEVICESTRINGEXTPROC>(
            eglGetProcAddress("eglQueryDeviceStringEXT"));
        EGLDeviceEXT devices[16];
        EGLint n = 0;
        if (query_devices && device_string && query_devices(16, devices, &n))
          for (EGLint i = 0; i < n && r.dpy == EGL_NO_DISPLAY; ++i)
            if (!has_word(device_string(devices[i], EGL_EXTENSIONS), "EGL_MESA_device_software"))
              try_init(get_platform(EGL_PLATFORM_DEVICE_EXT, devices[i], nullptr), "device");
      }
      if (r.dpy == EGL_NO_DISPLAY && has_word(client, "EGL_MESA_platform_surfaceless"))
        try_init(get_platform(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr),
                 "surfaceless");
    }
    if (r.dpy == EGL_NO_DISPLAY && !try_init(eglGetDisplay(EGL_DEFAULT_DISPLAY), "default"))
      r.error = egl_error("eglInitialize");
    return r;
  }();
  return d;
}

// Whether some EGL device may be a hardware GPU: false when the devices
// can be listed (EGL_EXT_device_enumeration) and each is a software one
// (EGL_MESA_device_software), or when EGL_PLATFORM names a platform and no
// devices are listed; true otherwise (then gl_info() decides). Cached.
inline bool hardware_gl_possible() {
  static const bool answer = [] {
    const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    auto query_devices =
        reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
    auto device_string = reinterpret_cast<PFNEGLQUERYDEVICESTRINGEXTPROC>(
        eglGetProcAddress("eglQueryDeviceStringEXT"));
    if (!has_word(client, "EGL_EXT_device_enumeration") || !query_devices || !device_string)
      return true;
    EGLDeviceEXT devices[16];
    EGLint n = 0;
    if (!query_devices(16, devices, &n)) return true;
    for (EGLint i = 0; i < n; ++i)
      if (!has_word(device_string(devices[i], EGL_EXTENSIONS), "EGL_MESA_device_software"))
        return true;
    return false;
  }();
  return answer;
}

// Mesa's llvmpipe (Debian 12) crashed inside a draw in one context while
// another thread drew in another (an lffragment per camera drawing with
// GL: about one run in ten of tests/test_gst.cpp). So on a software
// rasteriser the process's GL work runs one context at a time: contexts
// are made, destroyed and current under this lock (a GPU driver runs
// contexts in parallel; there it is held only while making and destroying).
inline std::recursive_mutex& gl_lock() {
  static std::recursive_mutex m;
  return m;
}

// A GLES 3 context of its own, current only inside a Current scope.
struct Context {
  EGLDisplay dpy = EGL_NO_DISPLAY;
  EGLContext ctx = EGL_NO_CONTEXT;
  EGLSurface surface = EGL_NO_SURFACE;  // a 1x1 pbuffer where surfaceless contexts are not offered

  // Returns "" on success, else why not.
  std::string create() {
    std::lock_guard<std::recursive_mutex> lock(gl_lock());
    const Display& d = display();
    if (d.dpy == EGL_NO_DISPLAY) return d.error;
    dpy = d.dpy;
    if (!eglBindAPI(EGL_OPENGL_ES_API)) return egl_error("eglBindAPI(GLES)");
    const char* ext = eglQueryString(dpy, EGL_EXTENSIONS);
    const bool surfaceless = has_word(ext, "EGL_KHR_surfaceless_context");
    const EGLint want[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_ES3_BIT, EGL_SURFACE_TYPE,
                           surfaceless ? 0 : EGL_PBUFFER_BIT, EGL_NONE};
    EGLConfig config = nullptr;
    EGLint n = 0;
    if (!eglChooseConfig(dpy, want, &config, 1, &n) || n < 1) {
      if (!surfaceless || !has_word(ext, "EGL_KHR_no_config_context"))
        return "no EGL config renders GLES 3";
      config = nullptr;  // EGL_NO_CONFIG_KHR
    }
    const EGLint attrs[] = {EGL_CONTEXT_MAJOR_VERSION, 3, EGL_NONE};
    ctx = eglCreateContext(dpy, config, EGL_NO_CONTEXT, attrs);
    if (ctx == EGL_NO_CONTEXT) return egl_error("eglCreateContext(GLES 3)");
    if (!surfaceless) {
      const EGLint pb[] = {EGL_WIDTH, 1, EGL_HEIGHT, 1, EGL_NONE};
      surface = eglCreatePbufferSurface(dpy, config, pb);
      if (surface == EGL_NO_SURFACE) return egl_error("eglCreatePbufferSurface");
    }
    if (!eglMakeCurrent(dpy, surface, surface, ctx)) return egl_error("eglMakeCurrent");
    eglMakeCurrent(dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    return "";
  }
  void destroy() {
    std::lock_guard<std::recursive_mutex> lock(gl_lock());
    if (ctx != EGL_NO_CONTEXT) eglDestroyContext(dpy, ctx);
    if (surface != EGL_NO_SURFACE) eglDestroySurface(dpy, surface);
    ctx = EGL_NO_CONTEXT;
    surface = EGL_NO_SURFACE;
  }
};

// Makes a context current on this thread for a scope (and releases it).
class Current {
 public:
  explicit Current(const Context& c) : c_(c), lock_(gl_lock()) {
    if (!eglMakeCurrent(c.dpy, c.surface, c.surface, c.ctx))
      throw std::runtime_error("GL: " + egl_error("eglMakeCurrent"));
    static const bool software = [] {
      const auto* r = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
      return !r || software_renderer(r);
    }();
    if (!software) lock_.unlock();  // contexts in parallel (gl_lock)
  }
  // Released before the lock (members are destroyed after this body).
  ~Current() { eglMakeCurrent(c_.dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT); }

 private:
  const Context& c_;
  std::unique_lock<std::recursive_mutex> lock_;
};

inline void check_gl(const char* where) {
  const GLenum e = glGetError();
  if (e != GL_NO_ERROR) {
    char buf[128];
    std::snprintf(buf, sizeof buf, "GL: %s failed (GL error 0x%04x)", where,
                  static_cast<unsigned>(e));
    throw std::runtime_error(buf);
  }
}

// Throws with the info log where a shader's or program's `status` is not
// GL_TRUE (the object is deleted first).
template <typename GetIv, typename GetLog, typename Delete>
inline void require(GLuint obj, GLenum status, GetIv get_iv, GetLog get_log, Delete del,
                    const char* what) {
  GLint ok = 0;
  get_iv(obj, status, &ok);
  if (ok) return;
  char log[2048] = {};
  get_log(obj, sizeof log, nullptr, log);
  del(obj);
  throw std::runtime_error(std::string("GL: ") + what + log);
}

inline GLuint compile(GLenum type, const char* src) {
  const GLuint s = glCreateShader(type);
  glShaderSource(s, 1, &src, nullptr);
  glCompileShader(s);
  require(s, GL_COMPILE_STATUS, glGetShaderiv, glGetShaderInfoLog, glDeleteShader,
          "shader does not compile: ");
  return s;
}

inline GLuint link(const char* vs, const char* fs) {
  const GLuint v = compile(GL_VERTEX_SHADER, vs), f = compile(GL_FRAGMENT_SHADER, fs);
  const GLuint p = glCreateProgram();
  glAttachShader(p, v);
  glAttachShader(p, f);
  glLinkProgram(p);
  glDeleteShader(v);
  glDeleteShader(f);
  require(p, GL_LINK_STATUS, glGetProgramiv, glGetProgramInfoLog, glDeleteProgram,
          "program does not link: ");
  return p;
}

}  // namespace lf::gl

#endif  // LF_HAVE_GL

// CalculiX as a second source of impulse responses (reference_fem/calculix.h).
#include <irdm_common/error.h>
#include <irdm_common/files.h>
#include <irdm_common/h5.h>
#include <reference_fem/calculix.h>
#include <reference_fem/elastodynamics.h>
#include <reference_fem/mesh.h>

#include "model_regions.h"

#include <algorithm>
#include <atomic>
#include <exception>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

namespace irdm::fem
{
  namespace
  {
    namespace fs = std::filesystem;

    std::string
    g17(const double x)
    {
      char b[32];
      std::snprintf(b, sizeof b, "%.17g", x);
      return b;
    }

    /// A number for a deck: CalculiX reads at most 20 characters of a field, so the most
    /// significant digits that fit (17 where they do; at least 14).
    std::string
    field(const double x)
    {
      char b[32];
      for (int digits = 17;; --digits)
        {
          std::snprintf(b, sizeof b, "%.*g", digits, x);
          if (std::strlen(b) <= 20)
            return b;
        }
    }

    /// HHT's alpha (CalculiX's ALPHA, in [-1/3, 0]) equal to the scene's integrator, or an
    /// InputError: HHT is generalized-alpha with alpha_m = 0.
    double
    hht_alpha(const Scene &s)
    {
      if (s.integrator == Integrator::newmark)
        return 0;
      if (std::abs(s.rho_inf - 0.5) <= 1e-12)
        return -1.0 / 3.0;
      throw InputError("calculix: CalculiX integrates with HHT-alpha, which is generalized-alpha "
                       "only at rho_inf = 0.5 (the scene has " + g17(s.rho_inf) + "); use "
                       "rho_inf 0.5 or the newmark integrator");
    }

    void
    check_scene(const Scene &s)
    {
      if (s.kinematics != Kinematics::linear)
        throw InputError("calculix: the impulse responses are linear: the scene must have linear "
                         "kinematics");
      if (s.fe_degree != 1)
        throw InputError("calculix: the deck uses CalculiX's linear tetrahedron C3D4: set "
                         "fe_degree 1");
      if (s.fixed_surfaces.empty())
        throw InputError("calculix: a free body (no fixed surface) is not supported: its "
                         "responses would carry the rigid motion");
      hht_alpha(s);
    }

    /// A number as CalculiX's .dat prints it: Fortran drops the 'E' of a three-digit exponent
    /// ("0.1234567-100").
    bool
    parse_fortran(const char *&p, double &x)
    {
      char *end = nullptr;
      x         = std::strtod(p, &end);
      if (end == p)
        return false;
      p = end;
      if ((*p == '-' || *p == '+') && p[1] >= '0' && p[1] <= '9')
        {
          const long e = std::strtol(p, &end, 10);
          x *= std::pow(10.0, static_cast<double>(e));
          p = end;
        }
      return true;
    }

    /// One run's displacements: [sample][3 * output + axis], from its .dat file.
    std::vector<double>
    read_dat(const std::string &dat, const std::map<long long, unsigned> &output_of_tag,
             const unsigned T, const double tau)
    {
      std::ifstream in(dat);
      if (!in)
        throw InputError("calculix: CalculiX wrote no '" + dat + "'");
      const unsigned      nout = static_cast<unsigned>(output_of_tag.size());
      std::vector<double> u(std::size_t(T) * 3 * nout, 0.0);
      std::vector<char>   seen(nout, 0);
      int                 s = -1;
      unsigned            found = 0;
      std::string         line;
      unsigned            line_no = 0;
      auto finish_block = [&] {
        if (s >= 0 && found != nout)
          throw InputError("calculix: '" + dat + "' sample " + std::to_string(s) + " holds " +
                           std::to_string(found) + " of " + std::to_string(nout) + " outputs");
      };
      while (std::getline(in, line))
        {
          ++line_no;
          const auto at = line.find("displacements");
          if (at != std::string::npos)
            {
              finish_block();
              ++s;
              if (s >= static_cast<int>(T))
                throw InputError("calculix: '" + dat + "' has more than " + std::to_string(T) +
                                 " samples");
              const auto t_at = line.find("time");
              double     t    = 0;
              const char *p   = t_at == std::string::npos ? nullptr : line.c_str() + t_at + 4;
              if (!p || !parse_fortran(p, t) || std::abs(t - (s + 1) * tau) > 1e-5 * tau * (s + 1))
                throw InputError("calculix: '" + dat + "' line " + std::to_string(line_no) +
                                 ": sample " + std::to_string(s) + " is not at t = " +
                                 g17((s + 1) * tau) + " s (CalculiX changed the step?)");
              std::fill(seen.begin(), seen.end(), 0);
              found = 0;
              continue;
            }
          const char *p = line.c_str();
          char       *end = nullptr;
          const long long tag = std::strtoll(p, &end, 10);
          if (end == p || s < 0)
            continue; // a blank line, or a header
          p = end;
          double v[3];
          for (double &x : v)
            if (!parse_fortran(p, x) || !std::isfinite(x))
              throw InputError("calculix: '" + dat + "' line " + std::to_string(line_no) +
                               ": not three displacements: '" + line + "'");
          const auto it = output_of_tag.find(tag);
          if (it == output_of_tag.end() || seen[it->second])
            throw InputError("calculix: '" + dat + "' line " + std::to_string(line_no) +
                             ": node " + std::to_string(tag) + " is not an output, or twice");
          seen[it->second] = 1;
          ++found;
          for (unsigned d = 0; d < 3; ++d)
            u[(std::size_t(s) * nout + it->second) * 3 + d] = v[d];
        }
      finish_block();
      if (s + 1 != static_cast<int>(T))
        throw InputError("calculix: '" + dat + "' has " + std::to_string(s + 1) + " of " +
                         std::to_string(T) + " samples");
      return u;
    }

    /// Runs `ccx -i job` (or `ccx -v`) in dir with one thread, its output in dir/ccx.log; the
    /// exit status (127: ccx could not be started).
    int
    run_ccx(const std::string &ccx, const std::string &dir, const bool version = false)
    {
      // Everything the child needs is made before fork: it only calls async-signal-safe
      // functions (open, chdir, dup2, execve). The environment is this process's with
      // CalculiX held to one thread; a program given by a relative path is made absolute
      // (the child changes folder first).
      const std::string log = dir + "/ccx.log";
      const std::vector<std::string> one_thread = {"OMP_NUM_THREADS=1", "CCX_NPROC_EQUATION_SOLVER=1",
                                                   "CCX_NPROC_STIFFNESS=1", "CCX_NPROC_RESULTS=1"};
      std::vector<std::string> env_text = one_thread;
      for (char **e = environ; *e != nullptr; ++e)
        {
          const std::string v = *e;
          bool overridden = false;
          for (const auto &o : one_thread)
            overridden = overridden || v.compare(0, o.find('=') + 1, o, 0, o.find('=') + 1) == 0;
          if (!overridden)
            env_text.push_back(v);
        }
      std::vector<char *> env;
      for (auto &e : env_text)
        env.push_back(e.data());
      env.push_back(nullptr);
      std::string a0 = ccx.find('/') == std::string::npos ? ccx : fs::absolute(ccx).string();
      std::string a1 = version ? "-v" : "-i", a2 = "job";
      char       *argv[] = {a0.data(), a1.data(), version ? nullptr : a2.data(), nullptr};
      const pid_t pid    = fork();
      if (pid < 0)
        return -1;
      if (pid == 0)
        {
          const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
          if (fd < 0 || chdir(dir.c_str()) != 0)
            _exit(126);
          dup2(fd, 1);
          dup2(fd, 2);
          execvpe(argv[0], argv, env.data());
          _exit(127);
        }
      int status = 0;
      while (waitpid(pid, &status, 0) < 0)
        if (errno != EINTR)
          return -1;
      return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    }

    std::string
    ccx_error(const std::string &dir)
    {
      std::ifstream in(dir + "/ccx.log");
      std::string   line, errors, last;
      while (std::getline(in, line))
        {
          if (line.find("ERROR") != std::string::npos && errors.size() < 600)
            errors += line + " ";
          if (!line.empty())
            last = line;
        }
      return errors.empty() ? last : errors;
    }

    /// "CalculiX Version 2.20", or an InputError when ccx cannot be started.
    std::string
    ccx_version(const std::string &ccx, const std::string &work)
    {
      const std::string dir = work + "/version";
      fs::create_directories(dir);
      if (run_ccx(ccx, dir, true) == 127)
        throw InputError("calculix: cannot run '" + ccx + "' (Debian: apt-get install calculix-ccx)");
      std::ifstream in(dir + "/ccx.log");
      std::string   line;
      while (std::getline(in, line))
        if (const auto at = line.find("Version"); at != std::string::npos)
          return "CalculiX " + line.substr(at);
      return "CalculiX (version not printed)";
    }

    /// The body as a CalculiX model: nodes, C3D4 elements, the fixed and output node sets,
    /// material, damping, and the force sample's amplitude. Every job includes it.
    void
    write_model_deck(const std::string &path, const Scene &s, const TetMesh &mesh,
                     const std::vector<long long> &output_tags, const unsigned T)
    {
      std::ostringstream o;
      o << "** The body of scene '" << s.name << "' (mesh " << mesh.file << "), written by irdm "
        << IRDM_VERSION << "; units SI (m, N, kg, s)\n*NODE\n";
      for (std::size_t v = 0; v < mesh.vertices.size(); ++v)
        o << mesh.node_tags[v] << "," << field(mesh.vertices[v][0]) << ","
          << field(mesh.vertices[v][1]) << "," << field(mesh.vertices[v][2]) << "\n";
      o << "*ELEMENT,TYPE=C3D4,ELSET=EALL\n";
      for (std::size_t e = 0; e < mesh.tets.size(); ++e)
        o << e + 1 << "," << mesh.node_tags[mesh.tets[e][0]] << ","
          << mesh.node_tags[mesh.tets[e][1]] << "," << mesh.node_tags[mesh.tets[e][2]] << ","
          << mesh.node_tags[mesh.tets[e][3]] << "\n";
      std::set<long long> fixed;
      for (const auto &name : s.fixed_surfaces)
        {
          const int tag = mesh.surface_tag(name);
          for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
            if (mesh.triangle_tags[t] == tag)
              for (const unsigned v : mesh.triangles[t])
                fixed.insert(mesh.node_tags[v]);
        }
      o << "*NSET,NSET=FIXED\n";
      for (const long long t : fixed)
        o << t << ",\n";
      o << "*NSET,NSET=OUT\n";
      for (const long long t : output_tags)
        o << t << ",\n";
      o << "*BOUNDARY\nFIXED,1,3\n*MATERIAL,NAME=BODY\n*ELASTIC\n" << field(s.youngs_modulus)
        << "," << field(s.poisson_ratio) << "\n*DENSITY\n" << field(s.density)
        << "\n*SOLID SECTION,ELSET=EALL,MATERIAL=BODY\n";
      if (s.rayleigh_alpha != 0 || s.rayleigh_beta != 0)
        o << "*DAMPING,ALPHA=" << field(s.rayleigh_alpha) << ",BETA=" << field(s.rayleigh_beta) << "\n";
      const double tau = s.time_step;
      // One force sample of 1 N: the HHT step reads the load at t_{n+1} and t_n linearly.
      o << "*AMPLITUDE,NAME=SAMPLE\n0,0," << field(tau) << ",1," << field(2 * tau) << ",0";
      if (T > 1)
        o << "," << field((T + 1) * tau) << ",0";
      o << "\n";
      write_text_file(path, o.str());
    }

    /// The surface triangles among the outputs (out_of_boundary: each boundary vertex's output,
    /// -1 if none), each with its physical surface's name: probes pick their triangles by it.
    void
    write_output_surface(h5::Writer &f, const SurfaceMesh &b, const std::vector<int> &out_of_boundary)
    {
      std::vector<int>         tri, tri_surface;
      std::vector<std::string> names;
      for (std::size_t t = 0; t < b.triangles.size(); ++t)
        {
          const auto &v = b.triangles[t];
          if (out_of_boundary[v[0]] < 0 || out_of_boundary[v[1]] < 0 || out_of_boundary[v[2]] < 0)
            continue;
          for (const unsigned x : v)
            tri.push_back(out_of_boundary[x]);
          // A triangle on no named surface gets a name: an empty last name would not survive
          // the comma-separated list.
          const std::string name = b.triangle_surface[t].empty() ? "unnamed" : b.triangle_surface[t];
          const auto        at   = std::find(names.begin(), names.end(), name);
          tri_surface.push_back(static_cast<int>(at - names.begin()));
          if (at == names.end())
            names.push_back(name);
        }
      if (!tri.empty())
        {
          std::string joined;
          for (const auto &n : names)
            joined += (joined.empty() ? "" : ",") + n;
          f.create_group("/surface");
          f.write("/surface/triangles", {tri.size() / 3, 3}, tri.data());
          f.write("/surface/triangle_surface", {tri_surface.size()}, tri_surface.data());
          f.attribute("/surface", "surface_names", joined);
        }
    }

    /// Runs CalculiX on decks 0 .. n_jobs - 1 (job_dir(j)/job.inp), `jobs` at a time, one
    /// thread each. The first CalculiX failure in words ("" if none); any other error in a
    /// worker is raised after every thread has joined.
    std::string
    run_decks(const CalculixOptions &options, const unsigned n_jobs,
              const std::function<std::string(unsigned)> &job_dir,
              const std::function<void(const std::string &)> &log)
    {
      std::atomic<unsigned> next{0}, done{0};
      std::mutex            m;
      std::string           failure;
      std::exception_ptr    thrown; // the first error in a worker, raised after the join
      auto worker = [&] {
        try
          {
            for (unsigned j; (j = next++) < n_jobs;)
              {
                const int status = run_ccx(options.ccx, job_dir(j));
                std::lock_guard<std::mutex> lock(m);
                if ((status != 0 || !fs::exists(job_dir(j) + "/job.dat")) && failure.empty())
                  failure = "input DoF " + std::to_string(j) + " (" + job_dir(j) + "): exit status " +
                            std::to_string(status) + ": " + ccx_error(job_dir(j));
                const unsigned d = ++done;
                if (log && (d % 10 == 0 || d == n_jobs))
                  log("calculix: " + std::to_string(d) + " of " + std::to_string(n_jobs) +
                      " input DoFs run");
              }
          }
        catch (...)
          {
            std::lock_guard<std::mutex> lock(m);
            if (!thrown)
              thrown = std::current_exception();
            next = n_jobs; // the others stop at their next job
          }
      };
      {
        std::vector<std::thread> pool;
        try
          {
            for (unsigned w = 0; w < std::max(1u, std::min(options.jobs, n_jobs)); ++w)
              pool.emplace_back(worker);
          }
        catch (...)
          {
            std::lock_guard<std::mutex> lock(m);
            if (!thrown)
              thrown = std::current_exception();
            next = n_jobs;
          }
        for (auto &t : pool)
          t.join();
      }
      if (thrown)
        std::rethrow_exception(thrown);
      return failure;
    }
  } // namespace

  CalculixReport
  calculix_responses(const Scene &scene, const CalculixOptions &options,
                     const std::function<void(const std::string &)> &log)
  {
    check_scene(scene);
    const double   alpha = hht_alpha(scene);
    const unsigned T     = options.length.value_or(scene.model.length);
    if (T == 0)
      throw InputError("calculix: the responses' length must be at least 1 sample");
    if (fs::exists(options.work_dir))
      throw InputError("calculix: the work folder '" + options.work_dir + "' exists; give a new one");

    // The regions exactly as `irdm precompute` picks them (boundary order).
    const ElasticDynamics fem(scene);
    const SurfaceMesh     b           = fem.boundary();
    const auto            dof_to_free = fem.vertex_dof_to_free();
    const auto out_v = select_vertices(scene.model.outputs, b, dof_to_free, "outputs");
    const auto in_v  = select_vertices(scene.model.inputs, b, dof_to_free, "inputs");
    const TetMesh mesh = read_gmsh(scene.mesh_file);

    CalculixReport rep;
    const unsigned nout = static_cast<unsigned>(out_v.size()), nin = static_cast<unsigned>(in_v.size());
    rep.n_outputs = 3 * nout;
    rep.n_inputs  = 3 * nin;
    rep.length    = T;
    std::vector<long long>         out_tags(nout);
    std::map<long long, unsigned>  output_of_tag;
    std::vector<int>               out_of_boundary(b.node_tags.size(), -1);
    for (unsigned i = 0; i < nout; ++i)
      {
        out_tags[i]                        = b.node_tags[out_v[i]];
        output_of_tag[out_tags[i]]         = i;
        out_of_boundary[out_v[i]]          = static_cast<int>(i);
      }
    std::vector<int> input_output(nin);
    for (unsigned k = 0; k < nin; ++k)
      {
        input_output[k] = out_of_boundary[in_v[k]];
        if (input_output[k] < 0)
          throw InputError("calculix: input vertex " + std::to_string(b.node_tags[in_v[k]]) +
                           " is not among the outputs (the exchange layout needs it there)");
      }

    fs::create_directories(options.work_dir);
    // The work folder goes when done, and on an error too unless CalculiX's own output tells
    // why (or --keep-work).
    struct WorkFolder
    {
      std::string path;
      bool        keep;
      ~WorkFolder()
      {
        std::error_code ec;
        if (!keep)
          fs::remove_all(path, ec);
      }
    } work{options.work_dir, options.keep_work};
    rep.ccx_version = ccx_version(options.ccx, options.work_dir);
    write_model_deck(options.work_dir + "/body.inp", scene, mesh, out_tags, T);

    // One deck per input DoF, run `jobs` at a time.
    const unsigned n_jobs = 3 * nin;
    auto job_dir = [&](const unsigned j) { return options.work_dir + "/dof_" + std::to_string(j); };
    for (unsigned j = 0; j < n_jobs; ++j)
      {
        fs::create_directories(job_dir(j));
        std::ostringstream o;
        o << "*INCLUDE,INPUT=../body.inp\n*STEP,INC=" << T + 10 << "\n*DYNAMIC,DIRECT,ALPHA="
          << field(alpha) << "\n" << field(scene.time_step) << "," << field(T * scene.time_step)
          << "\n*CLOAD,AMPLITUDE=SAMPLE\n" << b.node_tags[in_v[j / 3]] << "," << j % 3 + 1
          << ",1.0\n*NODE PRINT,NSET=OUT\nU\n*END STEP\n";
        write_text_file(job_dir(j) + "/job.inp", o.str());
      }
    const auto        t0      = std::chrono::steady_clock::now();
    const std::string failure = run_decks(options, n_jobs, job_dir, log);
    rep.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!failure.empty())
      {
        work.keep = true; // CalculiX's own output says why
        throw InputError("calculix: CalculiX failed on " + failure + " (its decks and output are "
                         "kept in '" + options.work_dir + "')");
      }

    // The exchange file: the responses per input DoF as CalculiX printed them.
    h5::Writer f(options.responses);
    f.attribute("/", "format", std::string("irdm-responses"));
    f.attribute("/", "format_version", 1LL);
    f.attribute("/", "time_step_s", scene.time_step);
    f.attribute("/", "convention", std::string("force_sample"));
    f.attribute("/", "units", std::string("SI: m, N, s; responses in m/N"));
    f.attribute("/", "source",
                rep.ccx_version + ", by irdm " + IRDM_VERSION + " calculix: scene '" + scene.name +
                  "', mesh " + scene.mesh_file + " (hash " + file_hash(scene.mesh_file) +
                  "), C3D4 (mass at the centroid), E " + g17(scene.youngs_modulus) + " Pa, nu " +
                  g17(scene.poisson_ratio) + ", rho " + g17(scene.density) +
                  " kg/m^3, Rayleigh alpha " + g17(scene.rayleigh_alpha) + " 1/s beta " +
                  g17(scene.rayleigh_beta) + " s, *DYNAMIC DIRECT HHT alpha " + g17(alpha) +
                  ", step " + g17(scene.time_step) + " s; displacements as printed (7 digits)");
    std::vector<double> xyz;
    f.create_group("/outputs");
    for (const unsigned v : out_v)
      xyz.insert(xyz.end(), b.coordinates[v].begin(), b.coordinates[v].end());
    f.write("/outputs/coordinates", {nout, 3}, xyz.data());
    f.write("/outputs/node_tags", {nout}, out_tags.data());
    xyz.clear();
    f.create_group("/inputs");
    for (const unsigned v : in_v)
      xyz.insert(xyz.end(), b.coordinates[v].begin(), b.coordinates[v].end());
    f.write("/inputs/coordinates", {nin, 3}, xyz.data());
    f.write("/inputs/output_index", {nin}, input_output.data());
    write_output_surface(f, b, out_of_boundary);
    f.create_dataset("/responses", {n_jobs, T, 3ull * nout}, true, 1);
    for (unsigned j = 0; j < n_jobs; ++j)
      {
        std::vector<double> u;
        try
          {
            u = read_dat(job_dir(j) + "/job.dat", output_of_tag, T, scene.time_step);
          }
        catch (const InputError &e)
          {
            work.keep = true;
            throw InputError(std::string(e.what()) + "; CalculiX said: " + ccx_error(job_dir(j)) +
                             " (its output is kept in '" + options.work_dir + "')");
          }
        f.write_rows("/responses", j, 1, u.data());
      }
    f.commit();
    return rep;
  }
} // namespace irdm::fem

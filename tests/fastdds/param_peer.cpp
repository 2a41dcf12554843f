// Fast DDS peer calling the truss_deploy node's parameter services as
// rmw_fastrtps_cpp does (`ros2 param` on ROS 2's default RMW): rq/<node>/
// <service>Request and rr/<node>/<service>Reply, the bare request written with
// related_sample_identity.writer_guid = the reply reader's GUID, the reply
// matched by related_sample_identity (tests/node/node_ros.rs). Types by hand
// from rcl_interfaces. It lists the parameters, gets rtf and model, sets rtf to
// PEER_SET_RTF together with a read-only one (refused), and gets rtf again.
// With PEER_ACTION=1 it drives /truss/simulate_steps instead (SimulateSteps,
// rcl_action's layout): a goal of 200 steps, its feedback and its result.
// Every loop is bounded in count and time; loopback only. Env: ROS_DOMAIN_ID,
// PEER_NODE (default /truss_deploy), PEER_SET_RTF (default 3.0). Prints one
// line `SUMMARY {json}`.
#include "common.hpp"

#include <array>


struct ParameterValue {  // rcl_interfaces/msg/ParameterValue
    uint8_t type = 0;
    bool bool_value = false;
    int64_t integer_value = 0;
    double double_value = 0;
    std::string string_value;
    std::vector<uint8_t> byte_array_value;
    std::vector<bool> bool_array_value;
    std::vector<int64_t> integer_array_value;
    std::vector<double> double_array_value;
    std::vector<std::string> string_array_value;
    void serialize(Cdr& c) const {
        c << type << bool_value << integer_value << double_value << string_value << byte_array_value
          << bool_array_value << integer_array_value << double_array_value << string_array_value;
    }
    void deserialize(Cdr& c) {
        c >> type >> bool_value >> integer_value >> double_value >> string_value >> byte_array_value >>
            bool_array_value >> integer_array_value >> double_array_value >> string_array_value;
    }
};

struct ListRq {
    std::vector<std::string> prefixes;
    uint64_t depth = 0;
    void serialize(Cdr& c) const { c << prefixes << depth; }
    void deserialize(Cdr& c) { c >> prefixes >> depth; }
    static const char* type() { return "rcl_interfaces::srv::dds_::ListParameters_Request_"; }
};
struct ListRp {
    std::vector<std::string> names, prefixes;
    void serialize(Cdr& c) const { c << names << prefixes; }
    void deserialize(Cdr& c) { c >> names >> prefixes; }
    static const char* type() { return "rcl_interfaces::srv::dds_::ListParameters_Response_"; }
};
struct GetRq {
    std::vector<std::string> names;
    void serialize(Cdr& c) const { c << names; }
    void deserialize(Cdr& c) { c >> names; }
    static const char* type() { return "rcl_interfaces::srv::dds_::GetParameters_Request_"; }
};
struct GetRp {
    std::vector<ParameterValue> values;
    void serialize(Cdr&) const {}
    void deserialize(Cdr& c) {
        uint32_t n = 0;
        c >> n;
        values.assign(n < 1000 ? n : 0, ParameterValue());
        for (auto& v : values) v.deserialize(c);
    }
    static const char* type() { return "rcl_interfaces::srv::dds_::GetParameters_Response_"; }
};
struct Parameter {
    std::string name;
    ParameterValue value;
};
struct SetRq {
    std::vector<Parameter> parameters;
    void serialize(Cdr& c) const {
        c << uint32_t(parameters.size());
        for (const auto& p : parameters) {
            c << p.name;
            p.value.serialize(c);
        }
    }
    void deserialize(Cdr&) {}
    static const char* type() { return "rcl_interfaces::srv::dds_::SetParameters_Request_"; }
};
struct SetRp {
    std::vector<std::pair<bool, std::string>> results;
    void serialize(Cdr&) const {}
    void deserialize(Cdr& c) {
        uint32_t n = 0;
        c >> n;
        results.assign(n < 1000 ? n : 0, {false, ""});
        for (auto& r : results) c >> r.first >> r.second;
    }
    static const char* type() { return "rcl_interfaces::srv::dds_::SetParameters_Response_"; }
};

// A service client as rmw_fastrtps_cpp makes one.
template <class Rq, class Rp>
struct FastClient {
    DataWriter* w = nullptr;
    DataReader* r = nullptr;
    FastClient(DomainParticipant* p, Publisher* pub, Subscriber* sub, const std::string& srv) {
        w = pub->create_datawriter(topic<Rq>(p, ("rq" + srv + "Request").c_str()), writer_qos(false, 1000));
        r = sub->create_datareader(topic<Rp>(p, ("rr" + srv + "Reply").c_str()), reader_qos(false, 1000));
    }
    // Waits (bounded) for the service and calls it; false if no reply in time.
    bool call(Rq& rq, Rp& out, double timeout_s) {
        const auto t0 = Clock::now();
        for (int k = 0; k < 100000 && secs_since(t0) < timeout_s; ++k) {
            PublicationMatchedStatus ps;
            SubscriptionMatchedStatus ss;
            w->get_publication_matched_status(ps);
            r->get_subscription_matched_status(ss);
            if (ps.current_count > 0 && ss.current_count > 0) break;
            std::this_thread::sleep_for(std::chrono::milliseconds(5));
        }
        eprosima::fastrtps::rtps::WriteParams wp;
        wp.related_sample_identity().writer_guid() = r->guid();
        if (!w->write(&rq, wp)) return false;
        const auto& sn = wp.sample_identity().sequence_number();
        const int64_t want = (int64_t(sn.high) << 32) | sn.low;
        for (int k = 0; k < 100000 && secs_since(t0) < timeout_s; ++k) {
            SampleInfo si;
            while (r->take_next_sample(&out, &si) == ReturnCode_t::RETCODE_OK) {
                const auto& rel = si.related_sample_identity;
                const int64_t seq = (int64_t(rel.sequence_number().high) << 32) | rel.sequence_number().low;
                if (si.valid_data && seq == want) return true;
            }
            std::this_thread::sleep_for(std::chrono::milliseconds(2));
        }
        return false;
    }
};

// SimulateSteps (simulation_interfaces/action) as rmw_fastrtps puts it on the wire.
using GoalId = std::array<uint8_t, 16>;
struct SendGoalRq {
    GoalId goal_id{};
    uint64_t steps = 0;
    void serialize(Cdr& c) const { c << goal_id << steps; }
    void deserialize(Cdr& c) { c >> goal_id >> steps; }
    static const char* type() { return "simulation_interfaces::action::dds_::SimulateSteps_SendGoal_Request_"; }
};
struct SendGoalRp {
    bool accepted = false;
    Time stamp;
    void serialize(Cdr&) const {}
    void deserialize(Cdr& c) { c >> accepted >> stamp.sec >> stamp.nanosec; }
    static const char* type() { return "simulation_interfaces::action::dds_::SimulateSteps_SendGoal_Response_"; }
};
struct GetResultRq {
    GoalId goal_id{};
    void serialize(Cdr& c) const { c << goal_id; }
    void deserialize(Cdr& c) { c >> goal_id; }
    static const char* type() { return "simulation_interfaces::action::dds_::SimulateSteps_GetResult_Request_"; }
};
struct GetResultRp {
    int8_t status = 0;
    uint8_t result = 0;
    std::string error_message;
    void serialize(Cdr&) const {}
    void deserialize(Cdr& c) { c >> status >> result >> error_message; }
    static const char* type() { return "simulation_interfaces::action::dds_::SimulateSteps_GetResult_Response_"; }
};
struct FeedbackMessage {
    GoalId goal_id{};
    uint64_t completed_steps = 0, remaining_steps = 0;
    void serialize(Cdr&) const {}
    void deserialize(Cdr& c) { c >> goal_id >> completed_steps >> remaining_steps; }
    static const char* type() { return "simulation_interfaces::action::dds_::SimulateSteps_FeedbackMessage_"; }
};

// A goal of 200 steps run to its end: {"accepted", "feedback": [[done, left]...], "status", "result"}.
static std::string action_calls(DomainParticipant* p, Publisher* pub, Subscriber* sub) {
    const std::string base = "/truss/simulate_steps/_action";
    FastClient<SendGoalRq, SendGoalRp> send(p, pub, sub, base + "/send_goal");
    FastClient<GetResultRq, GetResultRp> result(p, pub, sub, base + "/get_result");
    DataReader* fb = sub->create_datareader(topic<FeedbackMessage>(p, ("rt" + base + "/feedback").c_str()),
                                            reader_qos(false, 100));
    std::ostringstream js;
    if (!send.w || !result.w || !fb) return "{\"error\":\"endpoints\"}";
    SendGoalRq g;
    for (int k = 0; k < 16; ++k) g.goal_id[k] = uint8_t(200 + k);
    g.steps = 200;
    SendGoalRp gr;
    js << "{\"accepted\":" << (send.call(g, gr, 10.0) ? (gr.accepted ? "true" : "false") : "null");
    // feedback until the last one (bounded)
    js << ",\"feedback\":[";
    const auto t0 = Clock::now();
    bool first = true, last = false;
    for (int k = 0; k < 20000 && !last && secs_since(t0) < 20.0; ++k) {
        FeedbackMessage f;
        SampleInfo si;
        while (fb->take_next_sample(&f, &si) == ReturnCode_t::RETCODE_OK) {
            if (!si.valid_data || f.goal_id != g.goal_id) continue;
            js << (first ? "" : ",") << "[" << f.completed_steps << "," << f.remaining_steps << "]";
            first = false;
            last = f.remaining_steps == 0;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    GetResultRq rq;
    rq.goal_id = g.goal_id;
    GetResultRp rp;
    if (result.call(rq, rp, 20.0))
        js << "],\"status\":" << int(rp.status) << ",\"result\":" << int(rp.result) << "}";
    else
        js << "],\"status\":null}";
    return js.str();
}

static ParameterValue double_value(double x) {
    ParameterValue v;
    v.type = 3;
    v.double_value = x;
    return v;
}

int main() {
    const char* d = std::getenv("ROS_DOMAIN_ID");
    const int domain = d ? std::atoi(d) : 0;
    const char* n = std::getenv("PEER_NODE");
    const std::string node = n ? n : "/truss_deploy";
    const char* r = std::getenv("PEER_SET_RTF");
    const double rtf = r ? std::atof(r) : 3.0;
    DomainParticipant* p = make_participant(domain, "fastdds_param_peer");
    if (!p) {
        log("cannot create the participant");
        return 2;
    }
    Publisher* pub = p->create_publisher(PUBLISHER_QOS_DEFAULT);
    Subscriber* sub = p->create_subscriber(SUBSCRIBER_QOS_DEFAULT);
    const char* act = std::getenv("PEER_ACTION");
    if (act && std::string(act) == "1") {
        std::printf("SUMMARY %s\n", action_calls(p, pub, sub).c_str());
        std::fflush(stdout);
        p->delete_contained_entities();
        DomainParticipantFactory::get_instance()->delete_participant(p);
        return 0;
    }
    FastClient<ListRq, ListRp> list(p, pub, sub, node + "/list_parameters");
    FastClient<GetRq, GetRp> get(p, pub, sub, node + "/get_parameters");
    FastClient<SetRq, SetRp> set(p, pub, sub, node + "/set_parameters");
    if (!list.w || !list.r || !get.w || !get.r || !set.w || !set.r) {
        log("cannot create endpoints");
        return 2;
    }
    std::ostringstream js;
    js << "{";
    ListRq lq;
    ListRp lp;
    js << "\"list\":";
    if (list.call(lq, lp, 10.0)) {
        js << "[";
        for (size_t i = 0; i < lp.names.size(); ++i) js << (i ? "," : "") << json_str(lp.names[i]);
        js << "]";
    } else {
        js << "null";
    }
    GetRq gq;
    gq.names = {"rtf", "model"};
    GetRp gp;
    js << ",\"get\":";
    if (get.call(gq, gp, 8.0) && gp.values.size() == 2) {
        js << "[[" << int(gp.values[0].type) << "," << gp.values[0].double_value << "],["
           << int(gp.values[1].type) << "," << json_str(gp.values[1].string_value) << "]]";
    } else {
        js << "null";
    }
    SetRq sq;
    sq.parameters = {{"rtf", double_value(rtf)}, {"model", double_value(1.0)}};
    SetRp sp;
    js << ",\"set\":";
    if (set.call(sq, sp, 8.0)) {
        js << "[";
        for (size_t i = 0; i < sp.results.size(); ++i)
            js << (i ? "," : "") << "[" << (sp.results[i].first ? "true" : "false") << ","
               << json_str(sp.results[i].second) << "]";
        js << "]";
    } else {
        js << "null";
    }
    GetRq gq2;
    gq2.names = {"rtf"};
    GetRp gp2;
    js << ",\"rtf_after\":";
    if (get.call(gq2, gp2, 8.0) && gp2.values.size() == 1)
        js << gp2.values[0].double_value;
    else
        js << "null";
    js << "}";
    std::printf("SUMMARY %s\n", js.str().c_str());
    std::fflush(stdout);
    p->delete_contained_entities();
    DomainParticipantFactory::get_instance()->delete_participant(p);
    return 0;
}
